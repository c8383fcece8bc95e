// durer._core: a thin binding. Types, shapes and dtypes are checked by the Python package
// (durer/*.py); values (ranges, finiteness, names of options) by the core, whose
// std::invalid_argument becomes ValueError naming the argument. The binding itself only checks
// what keeps it memory-safe when called directly: array shapes, by requireShape.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <initializer_list>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>

#include "durer/render/Camera.h"
#include "durer/render/Cast.h"
#include "durer/render/Kernels.h"
#include "durer/render/Renderer.h"
#include "durer/Options.h"
#include "durer/scene/Limits.h"
#include "durer/scene/Scene.h"

namespace py = pybind11;
using namespace durer;

namespace {

using Triple = std::array<double, 3>;
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IdArray = py::array_t<int32_t, py::array::c_style | py::array::forcecast>;
using FlagArray = py::array_t<uint8_t, py::array::c_style | py::array::forcecast>;

using IndexArray = py::array_t<int64_t, py::array::c_style | py::array::forcecast>;

Vec3d vec(const Triple& t) { return Vec3d(t[0], t[1], t[2]); }

// The array has `shape` (kAny: any length in that axis), else ValueError naming it. Every array
// the binding reads goes through here, so a direct call with a wrong shape cannot read out of bounds.
constexpr py::ssize_t kAny = -1;
void requireShape(const py::array& a, const char* name, std::initializer_list<py::ssize_t> shape) {
  bool same = a.ndim() == static_cast<py::ssize_t>(shape.size());
  std::string wanted = "(";
  py::ssize_t axis = 0;
  for (const py::ssize_t n : shape) {
    if (same && n != kAny && a.shape(axis) != n) same = false;
    wanted += (axis++ ? ", " : "") + (n == kAny ? std::string("N") : std::to_string(n));
  }
  if (!same) throw py::value_error(std::string(name) + " must have shape " + wanted + (shape.size() == 1 ? ",)" : ")"));
}

// An add's optional colours, one per primitive: (count, 3); else ValueError naming `colors`.
CornerValues colorArray(const std::optional<DoubleArray>& colors, py::ssize_t count) {
  if (!colors) return {};
  requireShape(*colors, "colors", {count, 3});
  return {colors->data(), false};
}

// Triangles' colours, or a mesh's colours or normals (`name`): one per vertex (or triangle), (count, 3),
// or one per corner of each of `corners` triangles, (corners, 3, 3).
CornerValues cornerValues(const std::optional<DoubleArray>& values, py::ssize_t count, py::ssize_t corners,
                          const char* name = "colors") {
  if (!values) return {};
  if (values->ndim() != 3) {
    requireShape(*values, name, {count, 3});
    return {values->data(), false};
  }
  requireShape(*values, name, {corners, 3, 3});
  return {values->data(), true};
}

// An option table's names, in its order (Options.h).
template <typename Enum, size_t N>
py::tuple names(const OptionName<Enum> (&table)[N]) {
  py::tuple t(N);
  for (size_t i = 0; i < N; ++i) t[i] = table[i].name;
  return t;
}

// MATERIAL_FIELDS: (name, components, default) per field of Material, in the struct's order.
py::tuple materialFields() {
  const Material defaults;
  py::list fields;
  for (const MaterialField& f : kMaterialFields) {
    py::object value = f.color ? py::object(py::make_tuple((defaults.*f.color).x, (defaults.*f.color).y,
                                                              (defaults.*f.color).z))
                               : py::object(py::float_(defaults.*f.scalar));
    fields.append(py::make_tuple(f.name, f.components(), value));
  }
  return py::tuple(fields);
}

// LIMITS: {precision: {"coordinate": ..., "color": ...}} (Limits.h).
py::dict limitsTable() {
  py::dict table;
  for (const NumericLimits& l : kLimits) {
    py::dict row;
    row["coordinate"] = l.coordinate;
    row["color"] = l.color;
    table[l.precision] = row;
  }
  return table;
}

// A material from keyword arguments named as its fields; a field not given keeps its default.
Material materialFrom(const py::kwargs& given) {
  Material m;
  for (const auto& item : given) {
    const std::string name = py::str(item.first);
    const MaterialField* field = nullptr;
    for (const MaterialField& f : kMaterialFields) {
      if (name == f.name) field = &f;
    }
    if (!field) throw py::type_error("add_material got an unexpected field '" + name + "'");
    if (field->color) {
      m.*field->color = vec(item.second.cast<Triple>());
    } else {
      m.*field->scalar = item.second.cast<double>();
    }
  }
  return m;
}

// A (3, 4) world-from-object matrix (the package checks shapes) as an Affine; none: null.
struct OptionalAffine {
  Affined value;
  bool present = false;
  explicit OptionalAffine(const std::optional<DoubleArray>& m) {
    if (!m) return;
    requireShape(*m, "transform", {3, 4});
    const auto a = m->unchecked<2>();
    for (int i = 0; i < 3; ++i) value.row[i] = Vec3d(a(i, 0), a(i, 1), a(i, 2)), value.offset[i] = a(i, 3);
    present = true;
  }
  const Affined* get() const { return present ? &value : nullptr; }
};

// (N, 3, 4) world-from-object matrices (the package checks shapes) as Affines.
std::vector<Affined> affines(const DoubleArray& matrices, const char* field) {
  requireShape(matrices, field, {kAny, 3, 4});
  const auto t = matrices.unchecked<3>();
  std::vector<Affined> maps(static_cast<size_t>(matrices.shape(0)));
  for (py::ssize_t n = 0; n < matrices.shape(0); ++n) {
    Affined& m = maps[static_cast<size_t>(n)];
    for (int i = 0; i < 3; ++i) m.row[i] = Vec3d(t(n, i, 0), t(n, i, 1), t(n, i, 2)), m.offset[i] = t(n, i, 3);
  }
  return maps;
}

// Whether `materials` holds one id for all n primitives (false) or one each (true).
bool perPrimitive(const IdArray& materials, size_t n) {
  if (materials.ndim() == 1 && materials.shape(0) == 1) return false;
  requireShape(materials, "material", {static_cast<py::ssize_t>(n)});
  return true;
}
Triple triple(const Vec3d& v) { return {v.x, v.y, v.z}; }

CameraSpec cameraSpec(const std::string& projection, const Triple& center, const Triple& direction,
                      const Triple& up, double size, const std::string& fit, double shiftX, double shiftY,
                      double pixelAspect, double tMin, double tMax, bool clipPlanes, double apertureRadius,
                      double focusDistance, int apertureBlades, double apertureRotation, double apertureRatio) {
  CameraSpec spec;
  spec.projection = optionNamed(kProjectionNames, projection, "projection");
  spec.center = vec(center);
  spec.direction = vec(direction);
  spec.up = vec(up);
  spec.size = size;
  spec.fit = optionNamed(kFitNames, fit, "fit");
  spec.shiftX = shiftX;
  spec.shiftY = shiftY;
  spec.pixelAspect = pixelAspect;
  spec.tMin = tMin;
  spec.tMax = tMax;
  spec.clipPlanes = clipPlanes;
  spec.apertureRadius = apertureRadius;
  spec.focusDistance = focusDistance;
  spec.apertureBlades = apertureBlades;
  spec.apertureRotation = apertureRotation;
  spec.apertureRatio = apertureRatio;
  validate(spec);
  return spec;
}

// Runs a long core job without the GIL; `poll(fraction) -> bool` (with the GIL) may cancel it.
template <typename Job>
auto withoutGil(JobControl& control, const py::function& poll, Job job) {
  const std::function<void()> pollWithGil = [&] {
    py::gil_scoped_acquire gil;
    if (poll(control.fraction()).template cast<bool>()) control.cancel = true;
  };
  py::gil_scoped_release release;
  return job(pollWithGil);
}

// The buffer of a requested pass (float32, or int32 for the id passes): out[name] when given (reused,
// e.g. frame after frame), else new. A new id buffer starts as misses (-1), so that the pixels a
// cancelled render did not reach hold an id that maps to something.
template <typename T>
T* target(const py::dict& out, const char* name, bool wanted, std::vector<py::ssize_t> shape, py::dict& result) {
  if (!wanted) return nullptr;
  py::array_t<T> a;
  if (out.contains(name) && !out[name].is_none()) {
    py::object given = out[name];
    if (!py::isinstance<py::array_t<T>>(given)) {
      const char* dtype = std::is_same_v<T, float> ? "float32" : "int32";
      throw py::type_error(std::string("out.") + name + " must be a " + dtype + " array");
    }
    a = given.cast<py::array_t<T>>();
    const bool sameShape = a.ndim() == static_cast<py::ssize_t>(shape.size()) &&
                           std::equal(shape.begin(), shape.end(), a.shape());
    if (!sameShape) throw py::value_error(std::string("out.") + name + " has the wrong shape for this render");
    if (!(a.flags() & py::array::c_style) || !a.writeable()) {
      throw py::value_error(std::string("out.") + name + " must be C-contiguous and writeable");
    }
  } else {
    a = py::array_t<T>(shape);
    if constexpr (std::is_same_v<T, int32_t>) std::fill_n(a.mutable_data(), a.size(), int32_t(-1));
  }
  result[name] = a;
  return a.mutable_data();
}

py::dict renderPy(const Scene& scene, const CameraSpec& camera, int width, int height, int spp, uint64_t seed,
                  const std::string& sampler, double targetError, int minSamples, double timeLimit,
                  const std::string& precision,
                  const std::string& method, const std::vector<std::string>& passes, const std::string& depthKind,
                  int threads, bool shadeBack, int maxBounces, double minWeight,
                  const std::optional<std::pair<int, double>>& ambientOcclusion, const py::function& poll,
                  const py::dict& out, const std::array<int, 4>& region) {
  RenderSettings settings;
  settings.width = width;
  settings.height = height;
  settings.samplesPerPixel = spp;
  settings.seed = seed;
  settings.sampler = optionNamed(kSamplerNames, sampler, "sampler");
  settings.targetError = targetError;
  settings.minSamples = minSamples;
  settings.timeLimit = timeLimit;
  settings.precision = optionNamed(kPrecisionNames, precision, "precision");
  settings.sphereMethod = optionNamed(kSphereMethodNames, method, "sphere_method");
  settings.passes = 0;
  for (const std::string& name : passes) settings.passes |= optionNamed(kPassNames, name, "passes");
  settings.depth = optionNamed(kDepthNames, depthKind, "depth");
  settings.threads = threads;
  settings.shadeBack = shadeBack;
  settings.maxBounces = maxBounces;
  settings.minWeight = minWeight;
  if (ambientOcclusion) settings.ambientOcclusion = {true, ambientOcclusion->first, ambientOcclusion->second};
  settings.region = {region[0], region[1], region[2], region[3]};
  validate(settings);
  const bool color = settings.passes & kPassColor;
  const py::ssize_t h = region[2] != 0 ? region[3] : height, w = region[2] != 0 ? region[2] : width;
  py::dict result;
  RenderTargets targets;
  targets.color = target<float>(out, "color", color, {h, w, 4}, result);
  targets.depth = target<float>(out, "depth", settings.passes & kPassDepth, {h, w}, result);
  targets.normal = target<float>(out, "normal", settings.passes & kPassNormal, {h, w, 3}, result);
  targets.objectId = target<int32_t>(out, "object_id", settings.passes & kPassObjectId, {h, w}, result);
  targets.materialId = target<int32_t>(out, "material_id", settings.passes & kPassMaterialId, {h, w}, result);
  if (settings.sampler == SamplerKind::Adaptive) {
    py::array_t<int32_t> counts({h, w});
    py::array_t<float> error({h, w});
    targets.samples = counts.mutable_data();
    targets.error = error.mutable_data();
    result["samples"] = counts;
    result["error"] = error;
  }
  JobControl control;
  const RenderStats stats = withoutGil(control, poll, [&](const std::function<void()>& p) {
    return render(scene, camera, settings, targets, control, p);
  });
  const RayCounters& c = stats.counters;
  py::dict s;
  s["rays"] = c.camera;
  s["shadow_rays"] = c.shadow;
  s["reflection_rays"] = c.reflection;
  s["refraction_rays"] = c.refraction;
  s["ao_rays"] = c.ambientOcclusion;
  s["shading_evaluations"] = c.shadingEvaluations;
  s["bounces_cut_by_depth"] = c.cutByDepth;
  s["bounces_cut_by_weight"] = c.cutByWeight;
  s["total_internal_reflections"] = c.totalInternalReflections;
  s["intersection_tests"] = c.intersectionTests;
  s["milliseconds"] = stats.milliseconds;
  s["threads"] = stats.threads;
  s["cancelled"] = stats.cancelled;
  if (settings.sampler == SamplerKind::Adaptive) {
    const AdaptiveStats& a = stats.adaptive;
    s["estimated_rmse"] = a.estimatedRmse;
    s["estimated_worst"] = a.estimatedWorst;
    s["rounds"] = a.rounds;
    s["probes"] = a.probes;
    s["time_limit_reached"] = a.timeLimitReached;
  }
  const EffectSet& e = stats.effects;
  py::list effects;
  if (color) effects.append(e.lit ? "diffuse" : "flat");
  if (e.colors) effects.append("colors");
  if (e.reflection) effects.append("reflection");
  if (e.refraction) effects.append("refraction");
  if (e.shadows) effects.append("shadows");
  if (e.specular) effects.append("specular");
  if (e.occlusion) effects.append("ambient_occlusion");
  effects.attr("sort")();
  s["effects"] = py::tuple(effects);
  result["stats"] = s;
  return result;
}

template <typename Real>
py::dict castIn(const Scene& scene, const CastInput& input, const py::function& poll) {
  const py::ssize_t n = static_cast<py::ssize_t>(input.count);
  const py::ssize_t records = input.anyHit ? 0 : n;  // an occlusion query writes t alone
  py::array_t<Real> t(n), normal({records, py::ssize_t(3)});
  py::array_t<int32_t> objectId(records), materialId(records);
  CastOutput<Real> output{t.mutable_data(), normal.mutable_data(), objectId.mutable_data(), materialId.mutable_data()};
  JobControl control;
  const CastStats stats = withoutGil(control, poll, [&](const std::function<void()>& p) {
    return cast<Real>(scene, input, output, control, p);
  });
  py::dict out;
  out["t"] = t;
  if (!input.anyHit) {
    out["normal"] = normal;
    out["object_id"] = objectId;
    out["material_id"] = materialId;
  }
  out["intersection_tests"] = stats.intersectionTests;
  out["milliseconds"] = stats.milliseconds;
  out["cancelled"] = control.cancel.load();
  return out;
}

py::dict castPy(const Scene& scene, const DoubleArray& origins, const DoubleArray& directions, double tMin,
                double tMax, const std::string& precision, const std::string& method, int threads,
                const py::function& poll, bool anyHit) {
  requireShape(origins, "origins", {kAny, 3});
  requireShape(directions, "directions", {origins.shape(0), 3});
  CastInput input;
  input.origins = origins.data();
  input.directions = directions.data();
  input.count = static_cast<size_t>(origins.shape(0));
  input.tMin = tMin;
  input.tMax = tMax;
  input.sphereMethod = optionNamed(kSphereMethodNames, method, "sphere_method");
  input.threads = threads;
  input.anyHit = anyHit;
  return optionNamed(kPrecisionNames, precision, "precision") == Precision::Float ? castIn<float>(scene, input, poll)
                                                       : castIn<double>(scene, input, poll);
}

template <typename Real>
py::tuple cameraRaysIn(const CameraSpec& spec, int width, int height) {
  const Camera<Real> camera(spec, width, height);
  const py::ssize_t n = static_cast<py::ssize_t>(width) * height;
  py::array_t<Real> origins({n, py::ssize_t(3)}), directions({n, py::ssize_t(3)});
  Real* o = origins.mutable_data();
  Real* d = directions.mutable_data();
  RayPacket<Real> packet;
  Real sx[kPacketSize], sy[kPacketSize];
  for (py::ssize_t first = 0; first < n; first += kPacketSize) {
    const int count = static_cast<int>(std::min<py::ssize_t>(kPacketSize, n - first));
    for (int k = 0; k < count; ++k) {
      sx[k] = static_cast<Real>((first + k) % width + 0.5);
      sy[k] = static_cast<Real>((first + k) / width + 0.5);
    }
    camera.generate(packet, sx, sy, count);
    for (int k = 0; k < count; ++k) {
      const py::ssize_t i = 3 * (first + k);
      o[i] = packet.ox[k], o[i + 1] = packet.oy[k], o[i + 2] = packet.oz[k];
      d[i] = packet.dx[k], d[i + 1] = packet.dy[k], d[i + 2] = packet.dz[k];
    }
  }
  return py::make_tuple(origins.reshape({py::ssize_t(height), py::ssize_t(width), py::ssize_t(3)}),
                        directions.reshape({py::ssize_t(height), py::ssize_t(width), py::ssize_t(3)}));
}

py::tuple cameraRaysPy(const CameraSpec& spec, int width, int height, const std::string& precision) {
  if (width < 1) throw py::value_error("width must be >= 1");
  if (height < 1) throw py::value_error("height must be >= 1");
  const Precision p = optionNamed(kPrecisionNames, precision, "precision");
  requireRaysWithin(spec, width, height, limitsFor(p));
  return p == Precision::Float ? cameraRaysIn<float>(spec, width, height) : cameraRaysIn<double>(spec, width, height);
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "Dürer's C++ ray-casting core (use the durer package, which checks arguments)";

  py::class_<CameraSpec>(m, "CameraSpec")
      .def(py::init(&cameraSpec), py::arg("projection"), py::arg("center"), py::arg("direction"), py::arg("up"),
           py::arg("size"), py::arg("fit"), py::arg("shift_x"), py::arg("shift_y"), py::arg("pixel_aspect"), py::arg("t_min"),
           py::arg("t_max"), py::arg("clip_planes") = false, py::arg("aperture_radius") = 0.0,
           py::arg("focus_distance") = 1.0, py::arg("aperture_blades") = 0, py::arg("aperture_rotation") = 0.0,
           py::arg("aperture_ratio") = 1.0);

  py::class_<Scene>(m, "Scene")
      .def(py::init<>())
      .def("add_material", [](Scene& s, const py::kwargs& fields) { return s.addMaterial(materialFrom(fields)); })
      .def(
          "add_spheres",
          [](Scene& s, const DoubleArray& centers, const DoubleArray& radii, const IdArray& materials,
             const std::optional<DoubleArray>& transform, const std::optional<DoubleArray>& colors,
             const std::optional<FlagArray>& oneSided) {
            requireShape(radii, "radii", {kAny});
            requireShape(centers, "centers", {radii.shape(0), 3});
            if (oneSided) requireShape(*oneSided, "one_sided", {radii.shape(0)});
            const size_t n = static_cast<size_t>(radii.shape(0));
            const bool each = perPrimitive(materials, n);
            return s.addSpheres(centers.data(), radii.data(), materials.data(), n, each, OptionalAffine(transform).get(),
                                colorArray(colors, radii.shape(0)), oneSided ? oneSided->data() : nullptr);
          },
          py::arg("centers"), py::arg("radii"), py::arg("materials"), py::arg("transform"), py::arg("colors") = py::none(),
          py::arg("one_sided") = py::none())
      .def(
          "move_spheres",
          [](Scene& s, const IdArray& ids, const DoubleArray& centers, const std::optional<DoubleArray>& radii) {
            requireShape(ids, "ids", {kAny});
            requireShape(centers, "centers", {ids.shape(0), 3});
            if (radii) requireShape(*radii, "radii", {ids.shape(0)});
            s.moveSpheres(ids.data(), centers.data(), radii ? radii->data() : nullptr, static_cast<size_t>(ids.shape(0)));
          },
          py::arg("ids"), py::arg("centers"), py::arg("radii"))
      .def(
          "add_plane",
          [](Scene& s, const Triple& normal, double offset, int32_t material,
             const std::optional<std::array<Triple, 3>>& bounds, const std::optional<DoubleArray>& transform) {
            const OptionalAffine m(transform);
            if (!bounds) return s.addPlane(vec(normal), offset, material, nullptr, m.get());
            const PlaneBounds b{vec((*bounds)[0]), vec((*bounds)[1]), vec((*bounds)[2])};
            return s.addPlane(vec(normal), offset, material, &b, m.get());
          },
          py::arg("normal"), py::arg("offset"), py::arg("material"), py::arg("bounds"), py::arg("transform"))
      .def(
          "add_triangles",
          [](Scene& s, const DoubleArray& vertices, const IdArray& materials, const std::optional<DoubleArray>& transform,
             const std::optional<DoubleArray>& colors) {
            requireShape(vertices, "vertices", {kAny, 3, 3});
            const size_t n = static_cast<size_t>(vertices.shape(0));
            const bool each = perPrimitive(materials, n);
            return s.addTriangles(vertices.data(), materials.data(), n, each, OptionalAffine(transform).get(),
                                  cornerValues(colors, vertices.shape(0), vertices.shape(0)));
          },
          py::arg("vertices"), py::arg("materials"), py::arg("transform"), py::arg("colors") = py::none())
      .def(
          "add_mesh",
          [](Scene& s, const DoubleArray& vertices, const IndexArray& faces, int32_t material,
             const std::optional<DoubleArray>& transform, const std::optional<DoubleArray>& colors,
             const std::optional<DoubleArray>& normals) {
            requireShape(vertices, "vertices", {kAny, 3});
            requireShape(faces, "faces", {kAny, 3});
            return s.addMesh(vertices.data(), static_cast<size_t>(vertices.shape(0)), faces.data(),
                             static_cast<size_t>(faces.shape(0)), material, OptionalAffine(transform).get(),
                             cornerValues(colors, vertices.shape(0), faces.shape(0)),
                             cornerValues(normals, vertices.shape(0), faces.shape(0), "normals"));
          },
          py::arg("vertices"), py::arg("faces"), py::arg("material"), py::arg("transform"), py::arg("colors") = py::none(),
          py::arg("normals") = py::none())
      .def(
          "add_mesh_instances",
          [](Scene& s, const DoubleArray& vertices, const IndexArray& faces, int32_t material,
             const DoubleArray& transforms, const std::optional<DoubleArray>& colors,
             const std::optional<DoubleArray>& instanceColors, const std::optional<DoubleArray>& normals) {
            requireShape(vertices, "vertices", {kAny, 3});
            requireShape(faces, "faces", {kAny, 3});
            const std::vector<Affined> maps = affines(transforms, "transforms");
            if (instanceColors) requireShape(*instanceColors, "instance_colors", {transforms.shape(0), 3});
            return s.addMeshInstances(vertices.data(), static_cast<size_t>(vertices.shape(0)), faces.data(),
                                      static_cast<size_t>(faces.shape(0)), material, maps.data(), maps.size(),
                                      cornerValues(colors, vertices.shape(0), faces.shape(0)),
                                      instanceColors ? instanceColors->data() : nullptr,
                                      cornerValues(normals, vertices.shape(0), faces.shape(0), "normals"));
          },
          py::arg("vertices"), py::arg("faces"), py::arg("material"), py::arg("transforms"),
          py::arg("colors") = py::none(), py::arg("instance_colors") = py::none(), py::arg("normals") = py::none())
      .def(
          "add_boxes",
          [](Scene& s, const DoubleArray& lo, const DoubleArray& hi, const IdArray& materials,
             const std::optional<DoubleArray>& transform, const std::optional<DoubleArray>& colors) {
            requireShape(lo, "lo", {kAny, 3});
            requireShape(hi, "hi", {lo.shape(0), 3});
            const size_t n = static_cast<size_t>(lo.shape(0));
            const bool each = perPrimitive(materials, n);
            return s.addBoxes(lo.data(), hi.data(), materials.data(), n, each, OptionalAffine(transform).get(),
                              colorArray(colors, lo.shape(0)));
          },
          py::arg("lo"), py::arg("hi"), py::arg("materials"), py::arg("transform"), py::arg("colors") = py::none())
      .def("add_directional_light",
           [](Scene& s, const Triple& d, const Triple& c, bool shadows, double halfAngle, int samples, bool soft) {
             s.addDirectionalLight(DirectionalLight{vec(d), vec(c), shadows, SoftShadows{halfAngle, samples, soft}});
           })
      .def("add_point_light",
           [](Scene& s, const Triple& p, const Triple& c, const Triple& attenuation, bool shadows, double radius,
              int samples, bool soft) {
             s.addPointLight(PointLight{vec(p), vec(c), vec(attenuation), shadows, SoftShadows{radius, samples, soft}});
           })
      .def("add_spot_light",
           [](Scene& s, const Triple& p, const Triple& d, const Triple& c, const Triple& attenuation,
              double cosHalfAngle, double blend, bool shadows, double radius, int samples, bool soft) {
             s.addSpotLight(SpotLight{vec(p), vec(d), vec(c), vec(attenuation), cosHalfAngle, blend, shadows,
                                      SoftShadows{radius, samples, soft}});
           })
      .def("add_area_light",
           [](Scene& s, const Triple& p, const Triple& u, const Triple& v, const Triple& c, bool ellipse, int samples,
              bool shadows) { s.addAreaLight(AreaLight{vec(p), vec(u), vec(v), vec(c), ellipse, samples, shadows}); })
      .def_property(
          "shading", [](const Scene& s) { return optionName(kShadingModeNames, s.shadingMode()); },
          [](Scene& s, const std::string& mode) { s.setShading(optionNamed(kShadingModeNames, mode, "shading")); })
      .def_property(
          "background",
          [](const Scene& s) {
            const Vec4d& b = s.background();
            return std::array<double, 4>{b.x, b.y, b.z, b.w};
          },
          [](Scene& s, const std::array<double, 4>& b) { s.setBackground(Vec4d(b[0], b[1], b[2], b[3])); })
      .def_property(
          "ambient", [](const Scene& s) { return triple(s.ambient()); },
          [](Scene& s, const Triple& a) { s.setAmbient(vec(a)); })
      .def_property_readonly("hierarchy_counts",
                             [](const Scene& s) {
                               const Scene::HierarchyCounts c = s.hierarchyCounts();
                               py::dict d;
                               d["built"] = c.built, d["refitted"] = c.refitted, d["rebuilt"] = c.rebuilt;
                               d["milliseconds"] = c.milliseconds;
                               return d;
                             })
      .def_property_readonly("sphere_count", [](const Scene& s) { return s.group().counts().spheres; })
      .def_property_readonly("plane_count", [](const Scene& s) { return s.group().counts().planes; })
      .def_property_readonly("triangle_count", [](const Scene& s) { return s.group().counts().triangles; })
      .def_property_readonly("stored_triangle_count", [](const Scene& s) { return s.group().counts().storedTriangles; })
      .def_property_readonly("box_count", [](const Scene& s) { return s.group().counts().boxes; })
      .def_property_readonly("transform_count", [](const Scene& s) { return s.group().counts().instances; })
      .def_property_readonly("material_count", [](const Scene& s) { return s.materials().size(); })
      .def_property_readonly("object_count", &Scene::objectCount)
      .def_property_readonly("light_count", [](const Scene& s) {
        return s.directionalLights().size() + s.pointLights().size() + s.spotLights().size() + s.areaLights().size();
      });

  m.def("render", &renderPy, py::arg("scene"), py::arg("camera"), py::arg("width"), py::arg("height"),
        py::arg("spp"), py::arg("seed"), py::arg("sampler"), py::arg("target_error"), py::arg("min_spp"), py::arg("time_limit"), py::arg("precision"), py::arg("sphere_method"), py::arg("passes"),
        py::arg("depth"), py::arg("threads"), py::arg("shade_back"), py::arg("max_bounces"),
        py::arg("min_weight"), py::arg("ambient_occlusion"), py::arg("poll"), py::arg("out"), py::arg("region"));
  m.def("cast", &castPy, py::arg("scene"), py::arg("origins"), py::arg("directions"), py::arg("t_min"),
        py::arg("t_max"), py::arg("precision"), py::arg("sphere_method"), py::arg("threads"), py::arg("poll"),
        py::arg("any_hit"));
  m.def("camera_rays", &cameraRaysPy, py::arg("camera"), py::arg("width"), py::arg("height"),
        py::arg("precision"));
  m.def("default_thread_count", &defaultThreadCount);
  m.def("is_invertible", [](const DoubleArray& m) { return isInvertible(OptionalAffine(m).value); }, py::arg("matrix"));
  m.def(
      "are_invertible",
      [](const DoubleArray& matrices) {
        const std::vector<Affined> maps = affines(matrices, "matrices");
        py::array_t<bool> out(static_cast<py::ssize_t>(maps.size()));
        for (size_t i = 0; i < maps.size(); ++i) out.mutable_data()[i] = isInvertible(maps[i]);
        return out;
      },
      py::arg("matrices"));

  m.attr("KERNEL_SET") = kernels().isa;  // the instruction set of the hot kernels this CPU runs
  m.attr("RENDER_LIMITS") = py::dict(py::arg("side") = kRenderLimits.side, py::arg("max_bounces") = kRenderLimits.maxBounces,
                                     py::arg("rays_per_hit") = kRenderLimits.raysPerHit);
  m.attr("MIRROR_GLINT_EXPONENT") = kMirrorGlintExponent;
  m.attr("PRECISIONS") = names(kPrecisionNames);
  m.attr("SPHERE_METHODS") = names(kSphereMethodNames);
  m.attr("SAMPLERS") = names(kSamplerNames);
  m.attr("PASSES") = names(kPassNames);
  py::list defaultPasses;
  for (const OptionName<PassFlags>& pass : kPassNames) {
    if (pass.value & kDefaultPasses) defaultPasses.append(pass.name);
  }
  m.attr("DEFAULT_PASSES") = py::tuple(defaultPasses);
  m.attr("DEPTHS") = names(kDepthNames);
  m.attr("PROJECTIONS") = names(kProjectionNames);
  m.attr("FITS") = names(kFitNames);
  m.attr("SHADING_MODES") = names(kShadingModeNames);
  m.attr("MATERIAL_FIELDS") = materialFields();
  m.attr("LIMITS") = limitsTable();
}
