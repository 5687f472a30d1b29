"""The .pvd time series a talus run writes (docs/output.md)."""
import os
import xml.etree.ElementTree as ET


def pvd_series(pvd_path):
    """(time, file path) of every output listed in a .pvd, in time order."""
    root = ET.parse(pvd_path).getroot()
    folder = os.path.dirname(pvd_path)
    return sorted((float(d.get("timestep")), os.path.join(folder, d.get("file"))) for d in root.iter("DataSet"))
