#pragma once
// HDF5 helpers shared by the checkpoint writer (checkpoint.cpp) and reader
// (checkpoint_read.cpp): the fields, their descriptions, handles, attribute
// access and the format number. Internal to src/io.
#include <hdf5.h>
#include <mpi.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "talus/core/errors.hpp"
#include "talus/particles/particles.hpp"

namespace talus::checkpoint_hdf5 {

enum class Kind { real, index, id };

struct FieldSpec {
  const char* swarm_name;
  const char* file_name;
  int components;
  Kind kind;
};

template <int dim>
std::vector<FieldSpec> checkpoint_fields() {
  return {{field::position, "position", dim, Kind::real},
          {field::velocity, "velocity", dim, Kind::real},
          {field::affine_velocity, "affine_velocity", dim * dim, Kind::real},
          {field::displacement, "displacement", dim, Kind::real},
          {field::mass, "mass", 1, Kind::real},
          {field::initial_volume, "initial_volume", 1, Kind::real},
          {field::deformation_gradient, "deformation_gradient", dim * dim, Kind::real},
          {field::volume_ratio, "volume_ratio", 1, Kind::real},
          {field::stress, "kirchhoff_stress", 6, Kind::real},
          {field::material_state, "material_state", max_state_size, Kind::real},
          {field::cumulative_plastic_strain, "cumulative_plastic_strain", 1, Kind::real},
          {field::separation_strain, "separation_strain", 1, Kind::real},
          {field::material_id, "material_id", 1, Kind::index},
          {field::body_id, "body_id", 1, Kind::index},
          {field::particle_id, "particle_id", 1, Kind::id}};
}

inline hid_t memory_type(Kind k) {
  switch (k) {
    case Kind::real: return H5T_NATIVE_DOUBLE;
    case Kind::index: return sizeof(PetscInt) == 8 ? H5T_NATIVE_INT64 : H5T_NATIVE_INT32;
    case Kind::id: return H5T_NATIVE_INT64;
  }
  return H5T_NATIVE_DOUBLE;
}

inline std::size_t element_size(Kind k) { return k == Kind::real ? sizeof(double) : k == Kind::index ? sizeof(PetscInt) : 8; }

inline void check(herr_t status, const std::string& what) {
  if (status < 0) throw std::runtime_error("HDF5: " + what + " failed");
}

// The same check on every rank of `comm` at once: a collective HDF5 call
// that failed on one rank only (its file-size limit or its share of a full
// disk) must make every rank leave the write at the same call, so that all
// close their handles (collective too) in the same order; a rank that threw
// alone would leave the others waiting in the next collective call forever.
inline void check_on_all(herr_t status, const std::string& what, MPI_Comm comm) {
  const int failed_here = status < 0;
  int failed_anywhere = 0;
  MPI_Allreduce(&failed_here, &failed_anywhere, 1, MPI_INT, MPI_MAX, comm);
  if (failed_anywhere)
    throw std::runtime_error("HDF5: " + what + (failed_here ? " failed" : " failed on another rank"));
}

// A closing guard for HDF5 handles.
struct Handle {
  hid_t id;
  herr_t (*close)(hid_t);
  Handle(hid_t i, herr_t (*c)(hid_t), const std::string& what) : id(i), close(c) {
    if (id < 0) throw std::runtime_error("HDF5: " + what + " failed");
  }
  ~Handle() { close(id); }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
};

template <class T>
inline void write_attribute(hid_t location, const char* name, hid_t type, const T& value) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose, "scalar space");
  Handle attr(H5Acreate2(location, name, type, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, name);
  check(H5Awrite(attr.id, type, &value), name);
}

inline void write_text_attribute(hid_t location, const char* name, const std::string& text) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, "string type");
  check(H5Tset_size(type.id, text.size() + 1), "string size");
  Handle space(H5Screate(H5S_SCALAR), H5Sclose, "scalar space");
  Handle attr(H5Acreate2(location, name, type.id, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, name);
  check(H5Awrite(attr.id, type.id, text.c_str()), name);
}

// What a dataset holds, for whoever opens the file (h5py, h5dump): text
// attributes `units`, `component_order` (multi-column datasets) and
// `description`. Written, never read back: the reader depends on the layout
// of checkpoint_fields(), not on these.
struct Description {
  std::string units, component_order, description;
};

inline void describe(hid_t dataset, const Description& d) {
  write_text_attribute(dataset, "units", d.units);
  if (!d.component_order.empty()) write_text_attribute(dataset, "component_order", d.component_order);
  write_text_attribute(dataset, "description", d.description);
}

// "x y" or "x y z".
inline std::string axis_names(int dim) { return dim == 2 ? "x y" : "x y z"; }

// A dim x dim matrix stored row-major: "xx xy yx yy" (first letter the row).
inline std::string row_major_names(int dim) {
  std::string text;
  for (int a = 0; a < dim; ++a)
    for (int b = 0; b < dim; ++b) text += std::string(text.empty() ? "" : " ") + "xyz"[a] + "xyz"[b];
  return text;
}

// The stress columns in the order the code stores them: the inverse of
// voigt_index (core/types.hpp), so that the attribute follows the storage.
inline std::string voigt_names() {
  std::string names[6];
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) names[voigt_index(i, j)] = std::string() + "xyz"[i] + "xyz"[j];
  std::string text;
  for (const std::string& n : names) text += (text.empty() ? "" : " ") + n;
  return text;
}

template <int dim>
inline Description describe_field(const std::string& name) {
  const std::string per_thickness = dim == 2 ? " (2D: per m of thickness)" : "";
  if (name == "position") return {"m", axis_names(dim), "particle position"};
  if (name == "velocity") return {"m/s", axis_names(dim), "particle velocity"};
  if (name == "affine_velocity")
    return {"1/s", row_major_names(dim), "APIC affine velocity C_p, C_ab = dv_a/dx_b, row-major"};
  if (name == "displacement") return {"m", axis_names(dim), "position minus initial position"};
  if (name == "mass") return {dim == 2 ? "kg/m" : "kg", "", "particle mass" + per_thickness};
  if (name == "initial_volume")
    return {dim == 2 ? "m^2" : "m^3", "", "particle volume at seeding" + per_thickness};
  if (name == "deformation_gradient")
    return {"1", row_major_names(dim), "deformation gradient F, F_ab = dx_a/dX_b, row-major"};
  if (name == "volume_ratio")
    return {"1", "", "J = V / V0, the product of det(I + h grad v) over the steps (the volume; det F from F's entries "
                     "loses its digits once a long stretch makes F ill-conditioned)"};
  if (name == "kirchhoff_stress")
    return {"Pa", voigt_names(),
            "Kirchhoff stress tau = J sigma, tension positive, Voigt order (not ParaView's xx yy zz xy yz xz "
            "of the .vtu files); in 2D plane strain zz is the out-of-plane stress and yz = xz = 0"};
  if (name == "material_state")
    return {"1", "", "internal variables of the material: drucker_prager column 0 the hardening variable alpha; "
                     "unused columns 0"};
  if (name == "cumulative_plastic_strain") return {"1", "", "accumulated equivalent plastic strain"};
  if (name == "separation_strain") return {"1", "", "logarithmic volumetric strain of the voids opened at the apex"};
  if (name == "material_id") return {"1", "", "index into the case's materials (from 0)"};
  if (name == "body_id") return {"1", "", "index into the case's bodies (from 0)"};
  if (name == "particle_id") return {"1", "", "global particle number, unique and stable"};
  throw std::logic_error("no description of the checkpoint field " + name);
}

// 3: the case fingerprint of grid, gravity, boundaries, contact and
// transfer from their parsed values (2026-11-25); 2: all sections as YAML
// text, the same day; 1 (no attribute): before, without a fingerprint.
// 4: the energy balance; 5: materials fingerprinted from their parsed
// parameters (2026-11-25); 6: /obstacles (the obstacle loads) and the
// self-describing attributes (units, component order, case file); 7: the
// output directory (restart branches); 8: the volume ratio J (2026-11-27;
// format 7 is still read, with J = det F).
constexpr int checkpoint_format = 8;
constexpr int oldest_checkpoint_format = 7;

// A damaged checkpoint: what is wrong with it, for "not a valid talus checkpoint: <what>".
struct Damaged : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// An attribute of the expected class (integer, float or string) and a scalar
// dataspace, checked before HDF5 reads it into memory of that class.
inline Handle open_attribute(hid_t location, const char* name, H5T_class_t expected) {
  if (H5Aexists(location, name) <= 0) throw Damaged(std::string("no attribute ") + name);
  Handle attr(H5Aopen(location, name, H5P_DEFAULT), H5Aclose, std::string("attribute ") + name);
  Handle type(H5Aget_type(attr.id), H5Tclose, "attribute type");
  Handle space(H5Aget_space(attr.id), H5Sclose, "attribute space");
  if (H5Tget_class(type.id) != expected || H5Sget_simple_extent_type(space.id) != H5S_SCALAR)
    throw Damaged(std::string("attribute ") + name + " has the wrong type or shape");
  return Handle(H5Aopen(location, name, H5P_DEFAULT), H5Aclose, std::string("attribute ") + name);
}

template <class T>
T read_attribute(hid_t location, const char* name, hid_t type) {
  T value{};
  const Handle attr = open_attribute(location, name, H5Tget_class(type));
  check(H5Aread(attr.id, type, &value), name);
  return value;
}

inline std::string read_text_attribute(hid_t location, const char* name) {
  const Handle attr = open_attribute(location, name, H5T_STRING);
  Handle type(H5Aget_type(attr.id), H5Tclose, "attribute type");
  if (H5Tis_variable_str(type.id) > 0) throw Damaged(std::string("attribute ") + name + " has the wrong type");
  const std::size_t size = H5Tget_size(type.id);
  if (size == 0 || size > (std::size_t(1) << 28)) throw Damaged(std::string("attribute ") + name + " has a bad size");
  std::string text(size, '\0');
  check(H5Aread(attr.id, type.id, text.data()), name);
  text.resize(text.find('\0') == std::string::npos ? text.size() : text.find('\0'));
  return text;
}


}  // namespace talus::checkpoint_hdf5
