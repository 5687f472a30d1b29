"""The .pvd time series a talus run writes (docs/output.md)."""
import os
import xml.etree.ElementTree as ET


def pvd_series(pvd_path):
    """(time, file path) of every output listed in a .pvd, in time order."""
    root = ET.parse(pvd_path).getroot()
    folder = os.path.dirname(pvd_path)
    return sorted((float(d.get("timestep")), os.path.join(folder, d.get("file"))) for d in root.iter("DataSet"))


def read_particles(path, names=()):
    """(positions, [point arrays named in `names`]) of one .vtu or .pvtu a
    talus run wrote, as numpy arrays; an array the file lacks is None."""
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    reader = vtk.vtkXMLPUnstructuredGridReader() if path.endswith(".pvtu") else vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    data = grid.GetPointData()
    arrays = [data.GetArray(n) for n in names]
    return vtk_to_numpy(grid.GetPoints().GetData()), [vtk_to_numpy(a) if a is not None else None for a in arrays]
