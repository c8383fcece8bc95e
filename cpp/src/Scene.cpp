#include "durer/scene/Scene.h"

#include "durer/render/WorkQueue.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>

#include "durer/math/Float.h"
#include "durer/scene/Validate.h"

namespace durer {

namespace {

std::string sphereField(size_t i) {
  return "centers[" + std::to_string(i) + "] ± radii[" + std::to_string(i) + "]";
}

Vec3d vec3At(const double* p, size_t i) { return Vec3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }

// Vector i of p, unit: a normal as a triangle's corner keeps it (checked finite and nonzero; scaled by
// a power of two first, exactly, so that neither a huge nor a tiny one over- or underflows).
Vec3d unitAt(const double* p, size_t i) {
  const Vec3d v = vec3At(p, i);
  const double largest = std::max(std::fabs(v.x), std::max(std::fabs(v.y), std::fabs(v.z)));
  const int e = -std::ilogb(largest);
  const Vec3d scaled(std::scalbn(v.x, e), std::scalbn(v.y, e), std::scalbn(v.z, e));
  return scaled / glm::length(scaled);
}

// The `count` colours of an add (count x 3 doubles, or none if null) finite, >= 0 and within the
// colour limit; else an error naming colour i as field(i).
template <typename Field>
void requireColors(const double* values, size_t count, const Field& field) {
  if (!values) return;
  const double limit = widestLimits().color;
  for (size_t i = 0; i < count; ++i) {
    const Vec3d c = vec3At(values, i);
    // NaN fails every comparison, so it too takes the slow path, which names it.
    if (!(c.x >= 0 && c.y >= 0 && c.z >= 0 && c.x <= limit && c.y <= limit && c.z <= limit)) {
      requireNonNegativeColor(c, field(i));
    }
  }
}

// A mesh's `count` normals finite and nonzero; else an error naming normal i as field(i).
template <typename Field>
void requireNormals(const double* values, size_t count, const Field& field) {
  if (!values) return;
  for (size_t i = 0; i < count; ++i) {
    const Vec3d n = vec3At(values, i);
    if (!(std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z))) requireFinite(n, field(i));
    if (n == Vec3d(0)) fail(field(i) + " = (0, 0, 0) has no direction: a normal must be nonzero");
  }
}

std::string colorField(size_t i) { return "colors[" + std::to_string(i) + "]"; }
std::string cornerColorField(size_t i) {
  return "colors[" + std::to_string(i / 3) + "][" + std::to_string(i % 3) + "]";
}

// One field of a material within its bound (MaterialField), finite; else an error naming the field.
void requireWithinBound(const MaterialField& field, const Material& material) {
  const bool positive = field.bound == MaterialField::Bound::Positive;
  const Vec3d value = field.color ? material.*field.color : Vec3d(material.*field.scalar);
  for (int i = 0; i < field.components(); ++i) {
    if (std::isfinite(value[i]) && (positive ? value[i] > 0 : value[i] >= 0)) continue;
    std::ostringstream message;
    message << field.name << " must be finite and " << (positive ? "> 0" : ">= 0");
    if (field.color) {
      message << " in each channel, got (" << value.x << ", " << value.y << ", " << value.z << ")";
    } else {
      message << ", got " << value.x;
    }
    fail(message.str());
  }
  std::ostringstream shown;
  if (field.color) {
    shown << "(" << value.x << ", " << value.y << ", " << value.z << ")";
  } else {
    shown << value.x;
  }
  requireColorWithin(field.color ? maxAbs(value) : value.x, field.name, shown.str());
}
}  // namespace

Scene::Scene() { m_materials.push_back(Material{}); }

template <typename Set>
void Scene::prepareColors(Set& set, bool given) {
  if (!given) return;
  m_colored = true;
  if (!set.colored()) set.startColors([this](int32_t material) { return m_materials[static_cast<size_t>(material)].diffuse; });
}

template <typename Set, typename Prim, typename ColorsOf>
void Scene::addTo(Set& set, const Prim& primitive, int32_t material, int32_t objectId, bool given,
                  const ColorsOf& colorsOf) {
  if (given) return set.add(primitive, material, objectId, colorsOf());
  if (!set.colored()) return set.add(primitive, material, objectId);
  typename Set::Colors kd;
  kd.fill(m_materials[static_cast<size_t>(material)].diffuse);
  set.add(primitive, material, objectId, kd);
}

void Scene::requireMaterial(int32_t material, const char* field) const {
  if (material < 0 || static_cast<size_t>(material) >= m_materials.size()) {
    fail(std::string(field) + " " + std::to_string(material) + " is not a material id (the scene has " +
         std::to_string(m_materials.size()) + " materials, ids 0.." + std::to_string(m_materials.size() - 1) + ")");
  }
}

std::unique_lock<std::mutex> Scene::changeGeometry() {
  std::unique_lock<std::mutex> lock(m_preparedMutex);
  m_preparedFloat = {};
  m_preparedDouble = {};
  return lock;
}

template <typename Real>
std::shared_ptr<const Group<Real>> Scene::prepared(int threads, bool hierarchies) const {
  std::lock_guard<std::mutex> lock(m_preparedMutex);
  Prepared<Real>& cached = [this]() -> Prepared<Real>& {
    if constexpr (std::is_same_v<Real, float>) return m_preparedFloat;
    else return m_preparedDouble;
  }();
  const int workers = threads > 0 ? threads : defaultThreadCount();
  const auto start = std::chrono::steady_clock::now();
  if (cached.group && hierarchies && !cached.hierarchies) {  // made again with it (renders holding it keep it)
    cached.group.reset();
    cached.moved = false;
  }
  if (cached.group && cached.moved) {
    // A render still tracing the old geometry holds it too: it cannot change under that render.
    if (cached.group.use_count() == 1) {
      m_hierarchyCounts.rebuilt += cached.group->refitFrom(m_group, workers);
      ++m_hierarchyCounts.refitted;
    } else {
      cached.group.reset();
    }
    cached.moved = false;
  }
  if (!cached.group) {
    cached.group = std::make_shared<Group<Real>>(m_group);
    cached.group->prepare(workers, hierarchies);
    cached.hierarchies = hierarchies;
    ++m_hierarchyCounts.built;
  }
  m_hierarchyCounts.milliseconds +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return cached.group;
}

Scene::HierarchyCounts Scene::hierarchyCounts() const {
  std::lock_guard<std::mutex> lock(m_preparedMutex);
  return m_hierarchyCounts;
}

template std::shared_ptr<const Group<float>> Scene::prepared<float>(int, bool) const;
template std::shared_ptr<const Group<double>> Scene::prepared<double>(int, bool) const;

int32_t Scene::takeObjectIds(size_t count) {
  if (count > static_cast<size_t>(std::numeric_limits<int32_t>::max() - m_objectCount)) {
    fail("the scene cannot hold more than 2^31 - 1 objects");
  }
  const int32_t first = m_objectCount;
  m_objectCount += static_cast<int32_t>(count);
  return first;
}

int32_t Scene::addMaterial(const Material& material) {
  for (const MaterialField& field : kMaterialFields) requireWithinBound(field, material);
  if (m_materials.size() >= static_cast<size_t>(std::numeric_limits<int32_t>::max())) fail("too many materials");
  m_materials.push_back(material);
  return static_cast<int32_t>(m_materials.size() - 1);
}

namespace {
// Centers (count x 3) finite, radii (count) finite and > 0, each sphere within the widest limits;
// returns the index of the sphere that reaches farthest and how far.
std::pair<size_t, double> requireSpheres(const double* centers, const double* radii, size_t count) {
  const double limit = widestLimits().coordinate;
  size_t farthest = 0;
  double reach = 0;
  for (size_t i = 0; i < count; ++i) {
    const Vec3d c(centers[3 * i], centers[3 * i + 1], centers[3 * i + 2]);
    if (!(std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z))) {
      requireFinite(c, "centers[" + std::to_string(i) + "]");
    }
    if (!(std::isfinite(radii[i]) && radii[i] > 0)) requirePositive(radii[i], "radii[" + std::to_string(i) + "]");
    const double extent = maxAbs(c) + radii[i];
    if (extent > limit) requireWithin(extent, limit, sphereField(i), Scene::widestLimitsNote());
    if (extent > reach) reach = extent, farthest = i;
  }
  return {farthest, reach};
}
}  // namespace

int32_t Scene::addSpheres(const double* centers, const double* radii, const int32_t* materials, size_t count,
                          bool perSphere, const Affined* worldFromObject, const CornerValues& colors,
                          const uint8_t* oneSided) {
  // Validate everything before changing anything.
  requireTransform(worldFromObject);
  const auto [farthest, reach] = requireSpheres(centers, radii, count);
  requireMaterials(materials, count, perSphere);
  requireColors(colors.values, count, colorField);
  requirePrimitiveRoom(count);
  const Reach placed = requireReach(reach, sphereField(farthest), worldFromObject);
  const int32_t first = takeObjectIds(count);
  const auto lock = changeGeometry();
  Group<double>& group = groupFor(worldFromObject);
  SphereSet<double>& spheres = group.spheres();
  if (count) {
    m_sphereRuns.push_back({first, count, &group, spheres.size(), &group != &m_group, {}, placed,
                            spheres.size() + farthest});
    if (&group != &m_group) m_sphereRuns.back().worldFromObject = *worldFromObject;
  }
  const bool given = colors.values && count;
  prepareColors(spheres, given);
  spheres.reserve(spheres.size() + count);
  for (size_t i = 0; i < count; ++i) {
    const Vec3d c(centers[3 * i], centers[3 * i + 1], centers[3 * i + 2]);
    addTo(spheres, Sphere<double>{c, radii[i]}, materials[perSphere ? i : 0], first + static_cast<int32_t>(i), given,
          [&] { return SphereSet<double>::Colors{vec3At(colors.values, i)}; });
    if (oneSided && oneSided[i]) spheres.setOneSided(spheres.size() - 1);
  }
  return first;
}

void Scene::moveSpheres(const int32_t* ids, const double* centers, const double* radii, size_t count) {
  // Sphere i's run and its index in the run's group, kept in no array (1M moved spheres' 16 MB of
  // fresh pages took a quarter of a move): a move's ids mostly follow each other in one run, so each
  // lookup tries the run before it first.
  const SphereRun* hint = nullptr;
  const auto locate = [&](size_t i) -> std::pair<const SphereRun*, size_t> {
    const int32_t id = ids[i];
    if (!(hint && id >= hint->firstId && static_cast<size_t>(id - hint->firstId) < hint->count)) {
      const auto after = std::upper_bound(m_sphereRuns.begin(), m_sphereRuns.end(), id,
                                          [](int32_t value, const SphereRun& run) { return value < run.firstId; });
      if (after == m_sphereRuns.begin() || static_cast<size_t>(id - (after - 1)->firstId) >= (after - 1)->count) {
        fail("ids[" + std::to_string(i) + "] = " + std::to_string(id) + " is not the object id of a sphere");
      }
      hint = &*(after - 1);
    }
    return {hint, hint->start + static_cast<size_t>(id - hint->firstId)};
  };
  for (size_t i = 0; i < count; ++i) locate(i);  // every id checked before anything changes
  std::vector<double> kept;
  if (!radii) {
    kept.resize(count);
    for (size_t i = 0; i < count; ++i) {
      const auto [run, index] = locate(i);
      kept[i] = run->group->spheres().primitive(index).radius;
    }
    radii = kept.data();
  }
  requireSpheres(centers, radii, count);
  // The farthest moved sphere of each run (a few runs: one per add), checked through its transform.
  // A sphere named twice counts both places: the reach may be the earlier's, farther (a float
  // render then refused where the later fits), never nearer than the spheres are.
  struct Farthest {
    const SphereRun* run;
    double extent;
    size_t index;
    bool movesFarthest = false;  // whether the run's farthest sphere is among those moved
  };
  std::vector<Farthest> farthest;
  for (size_t i = 0; i < count; ++i) {
    const double extent = maxAbs(Vec3d(centers[3 * i], centers[3 * i + 1], centers[3 * i + 2])) + radii[i];
    const SphereRun* run = locate(i).first;
    auto f = std::find_if(farthest.begin(), farthest.end(), [&](const Farthest& x) { return x.run == run; });
    if (f == farthest.end()) {
      farthest.push_back({run, extent, i});
      f = farthest.end() - 1;
    } else if (extent > f->extent) {
      f->extent = extent, f->index = i;
    }
    f->movesFarthest |= locate(i).second == run->farthest;
  }
  std::vector<Reach> placed;
  for (const Farthest& f : farthest) {
    placed.push_back(requireReach(f.extent, sphereField(f.index), f.run->transformed ? &f.run->worldFromObject : nullptr));
  }
  std::lock_guard<std::mutex> lock(m_preparedMutex);
  for (size_t i = 0; i < count; ++i) {
    const Vec3d c(centers[3 * i], centers[3 * i + 1], centers[3 * i + 2]);
    const auto [run, index] = locate(i);
    run->group->spheres().setSphere(index, {c, radii[i]});
  }
  for (size_t k = 0; k < farthest.size(); ++k) {
    const Farthest& f = farthest[k];
    SphereRun& run = m_sphereRuns[static_cast<size_t>(f.run - m_sphereRuns.data())];
    run.group->spheres().dropGrid();
    if (placed[k].magnitude >= run.reach.magnitude) {
      run.reach = placed[k], run.farthest = locate(f.index).second;
    } else if (f.movesFarthest) {
      measureReach(run);  // the farthest came nearer: another sphere may be the farthest now
    }
  }
  m_preparedFloat.moved = m_preparedDouble.moved = true;
}

void Scene::measureReach(SphereRun& run) {
  const SphereSet<double>& spheres = run.group->spheres();
  double reach = 0;
  size_t farthest = run.start;
  for (size_t j = run.start; j < run.start + run.count; ++j) {
    const Sphere<double>& sphere = spheres.primitive(j);
    const double extent = maxAbs(sphere.center) + sphere.radius;
    if (extent > reach) reach = extent, farthest = j;
  }
  // Within the widest limits: every sphere was checked when it was added or moved.
  run.reach = requireReach(reach, "the sphere of object id " + std::to_string(run.firstId + (farthest - run.start)),
                           run.transformed ? &run.worldFromObject : nullptr);
  run.farthest = farthest;
}

Scene::Reach Scene::reach() const {
  Reach all = m_reach;
  for (const SphereRun& run : m_sphereRuns) {
    if (run.reach.magnitude > all.magnitude) all.magnitude = run.reach.magnitude, all.field = run.reach.field;
    all.world = std::fmax(all.world, run.reach.world);
  }
  return all;
}

int32_t Scene::addPlane(const Vec3d& normal, double offset, int32_t material, const PlaneBounds* bounds,
                        const Affined* worldFromObject) {
  requireTransform(worldFromObject);
  requireNonZero(normal, "normal");
  requireFinite(offset, "offset");
  requireMaterial(material, "material");
  // Keep n·p = offset true for the unit normal: offset scales with 1/|normal|.
  const double largest = maxAbs(normal);
  const Vec3d scaled = normal / largest;
  const Vec3d unit = scaled / glm::length(scaled);
  const double unitOffset = offset / largest / glm::length(scaled);
  requireFinite(unitOffset, "offset / |normal|");
  Reach placed = requireReach(std::fabs(unitOffset), "offset / |normal|", worldFromObject);
  Plane<double> plane{unit, unitOffset * unit, false, Vec3d(0), Vec3d(0)};
  if (bounds) {
    requireFinite(bounds->corner, "bounds corner");
    requireNonZero(bounds->edge1, "bounds edge1");
    requireNonZero(bounds->edge2, "bounds edge2");
    // A relative tolerance: bounds usually come from a quad whose plane was fitted in single precision.
    constexpr double kTolerance = 1e-6;
    const double scale = std::fmax(1.0, std::fmax(std::fabs(unitOffset), glm::length(bounds->corner)));
    if (std::fabs(glm::dot(unit, bounds->corner) - unitOffset) > kTolerance * scale) {
      fail("bounds corner is not on the plane (normal·corner must equal offset)");
    }
    const Vec3d e1 = safeNormalize(bounds->edge1), e2 = safeNormalize(bounds->edge2);
    if (std::fabs(glm::dot(unit, e1)) > kTolerance) fail("bounds edge1 is not in the plane (normal·edge1 must be 0)");
    if (std::fabs(glm::dot(unit, e2)) > kTolerance) fail("bounds edge2 is not in the plane (normal·edge2 must be 0)");
    if (glm::length(glm::cross(e1, e2)) < kTolerance) fail("bounds edge1 and edge2 must not be parallel");
    const Vec3d c1 = glm::cross(bounds->edge2, unit), c2 = glm::cross(unit, bounds->edge1);
    plane.bounded = true;
    plane.point = bounds->corner;
    plane.dual1 = c1 / glm::dot(c1, bounds->edge1);
    plane.dual2 = c2 / glm::dot(c2, bounds->edge2);
    requireFinite(plane.dual1, "bounds edge1 (too long or too short)");
    requireFinite(plane.dual2, "bounds edge2 (too long or too short)");
    const Vec3d& c = bounds->corner;
    const double extent = std::fmax(
        std::fmax(maxAbs(c), maxAbs(c + bounds->edge1 + bounds->edge2)),
        std::fmax(maxAbs(c + bounds->edge1), maxAbs(c + bounds->edge2)));
    placed = requireReach(extent, "bounds (corner + edges)", worldFromObject);
  }
  requirePrimitiveRoom(1);
  const int32_t id = takeObjectIds(1);
  const auto lock = changeGeometry();
  groupFor(worldFromObject).planes().add(plane, material, id);
  noteReach(placed);
  return id;
}

namespace {
Triangle<double> makeTriangle(const Vec3d& v0, const Vec3d& v1, const Vec3d& v2) {
  const Vec3d n = glm::cross(v1 - v0, v2 - v0);
  const double largest = maxAbs(n);
  // A degenerate triangle keeps a zero normal: its test never reports a hit, so it is never read.
  const Vec3d unit = largest > 0 && std::isfinite(largest) ? safeNormalize(n) : Vec3d(0);
  return {v0, v1, v2, unit};
}

// The index of the point point(i) (of `count`) farthest from 0 by its largest |coordinate|; a point
// beyond the widest coordinate limit is an error naming field(i).
template <typename Point, typename Field>
size_t farthestPoint(size_t count, const Point& point, const Field& field) {
  const double limit = widestLimits().coordinate;
  size_t farthest = 0;
  for (size_t i = 0; i < count; ++i) {
    const double extent = maxAbs(point(i));
    if (extent > limit) requireWithin(extent, limit, field(i), Scene::widestLimitsNote());
    if (extent > maxAbs(point(farthest))) farthest = i;
  }
  return farthest;
}
}  // namespace

int32_t Scene::addTriangles(const double* vertices, const int32_t* materials, size_t count, bool perTriangle,
                            const Affined* worldFromObject, const CornerValues& colors) {
  requireTransform(worldFromObject);
  const auto field = [](size_t i) { return "vertices[" + std::to_string(i / 3) + "][" + std::to_string(i % 3) + "]"; };
  for (size_t i = 0; i < 3 * count; ++i) {
    const Vec3d v = vec3At(vertices, i);
    if (!(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z))) requireFinite(v, field(i));
  }
  const size_t farthest = farthestPoint(3 * count, [&](size_t i) { return vec3At(vertices, i); }, field);
  requireMaterials(materials, count, perTriangle);
  if (colors.perCorner) {
    requireColors(colors.values, 3 * count, cornerColorField);
  } else {
    requireColors(colors.values, count, colorField);
  }
  requirePrimitiveRoom(count);
  const Reach placed = requireReach(count ? maxAbs(vec3At(vertices, farthest)) : 0, field(farthest), worldFromObject);
  const int32_t first = takeObjectIds(count);
  const auto lock = changeGeometry();
  TriangleSet<double>& triangles = groupFor(worldFromObject).triangles();
  const bool given = colors.values && count;
  prepareColors(triangles, given);
  triangles.reserve(triangles.size() + count);
  for (size_t i = 0; i < count; ++i) {
    const auto colorsOf = [&] {
      const double* c = colors.values;
      return colors.perCorner ? TriangleSet<double>::Colors{vec3At(c, 3 * i), vec3At(c, 3 * i + 1), vec3At(c, 3 * i + 2)}
                              : TriangleSet<double>::Colors{vec3At(c, i), vec3At(c, i), vec3At(c, i)};
    };
    addTo(triangles, makeTriangle(vec3At(vertices, 3 * i), vec3At(vertices, 3 * i + 1), vec3At(vertices, 3 * i + 2)),
          materials[perTriangle ? i : 0], first + static_cast<int32_t>(i), given, colorsOf);
  }
  noteReach(placed);
  return first;
}

Scene::Reach Scene::requireMesh(const double* vertices, size_t vertexCount, const int64_t* faces, size_t faceCount,
                                int32_t material, const CornerValues& colors, const CornerValues& normals) const {
  const auto field = [](size_t i) { return "vertices[" + std::to_string(i) + "]"; };
  for (size_t i = 0; i < vertexCount; ++i) {
    const Vec3d v = vec3At(vertices, i);
    if (!(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z))) requireFinite(v, field(i));
  }
  const size_t farthest = farthestPoint(vertexCount, [&](size_t i) { return vec3At(vertices, i); }, field);
  for (size_t i = 0; i < 3 * faceCount; ++i) {
    if (faces[i] < 0 || static_cast<uint64_t>(faces[i]) >= vertexCount) {
      fail("faces[" + std::to_string(i / 3) + "][" + std::to_string(i % 3) + "] = " + std::to_string(faces[i]) +
           " is not a vertex index (the mesh has " + std::to_string(vertexCount) + " vertices)");
    }
  }
  requireMaterial(material, "material");
  if (colors.perCorner) {
    requireColors(colors.values, 3 * faceCount, cornerColorField);
  } else {
    requireColors(colors.values, vertexCount, colorField);
  }
  if (normals.perCorner) {
    requireNormals(normals.values, 3 * faceCount, [](size_t i) {
      return "normals[" + std::to_string(i / 3) + "][" + std::to_string(i % 3) + "]";
    });
  } else {
    requireNormals(normals.values, vertexCount, [](size_t i) { return "normals[" + std::to_string(i) + "]"; });
  }
  return requireReach(vertexCount ? maxAbs(vec3At(vertices, farthest)) : 0, field(farthest), nullptr);
}

void Scene::addMeshTo(TriangleSet<double>& triangles, const double* vertices, const int64_t* faces, size_t faceCount,
                      int32_t material, int32_t id, const CornerValues& colors, const CornerValues& normals) {
  const bool given = colors.values && faceCount;
  prepareColors(triangles, given);
  triangles.reserve(triangles.size() + faceCount);
  for (size_t f = 0; f < faceCount; ++f) {
    const size_t v0 = static_cast<size_t>(faces[3 * f]), v1 = static_cast<size_t>(faces[3 * f + 1]),
                 v2 = static_cast<size_t>(faces[3 * f + 2]);
    const auto colorsOf = [&] {
      const double* c = colors.values;
      return colors.perCorner ? TriangleSet<double>::Colors{vec3At(c, 3 * f), vec3At(c, 3 * f + 1), vec3At(c, 3 * f + 2)}
                              : TriangleSet<double>::Colors{vec3At(c, v0), vec3At(c, v1), vec3At(c, v2)};
    };
    addTo(triangles, makeTriangle(vec3At(vertices, v0), vec3At(vertices, v1), vec3At(vertices, v2)), material, id,
          given, colorsOf);
    if (normals.values) {
      const double* n = normals.values;
      triangles.smoothLast(normals.perCorner
                               ? TriangleSet<double>::Normals{unitAt(n, 3 * f), unitAt(n, 3 * f + 1), unitAt(n, 3 * f + 2)}
                               : TriangleSet<double>::Normals{unitAt(n, v0), unitAt(n, v1), unitAt(n, v2)});
    }
  }
}

int32_t Scene::addMesh(const double* vertices, size_t vertexCount, const int64_t* faces, size_t faceCount,
                       int32_t material, const Affined* worldFromObject, const CornerValues& colors,
                       const CornerValues& normals) {
  requireTransform(worldFromObject);
  const Reach mesh = requireMesh(vertices, vertexCount, faces, faceCount, material, colors, normals);
  requirePrimitiveRoom(faceCount);
  const Reach placed = requireReach(mesh.magnitude, mesh.field, worldFromObject);
  const int32_t id = takeObjectIds(1);
  const auto lock = changeGeometry();
  addMeshTo(groupFor(worldFromObject).triangles(), vertices, faces, faceCount, material, id, colors, normals);
  noteReach(placed);
  return id;
}

int32_t Scene::addMeshInstances(const double* vertices, size_t vertexCount, const int64_t* faces, size_t faceCount,
                                int32_t material, const Affined* worldFromObject, size_t count,
                                const CornerValues& colors, const double* instanceColors, const CornerValues& normals) {
  if (count == 0) fail("transforms must hold at least one matrix");
  for (size_t i = 0; i < count; ++i) requireTransform(&worldFromObject[i], "transforms[" + std::to_string(i) + "]");
  const Reach mesh = requireMesh(vertices, vertexCount, faces, faceCount, material, colors, normals);
  requireColors(instanceColors, count, [](size_t i) { return "instance_colors[" + std::to_string(i) + "]"; });
  if (faceCount > 0 && count > static_cast<size_t>(std::numeric_limits<int32_t>::max()) / faceCount) {
    fail("the scene cannot hold more than 2^31 - 1 primitives");
  }
  requirePrimitiveRoom(faceCount * count);  // each instance has its own range of packed indices
  Reach placed = mesh;
  placed.world = 0;
  for (size_t i = 0; i < count; ++i) {
    placed.world = std::fmax(placed.world, requireReach(mesh.magnitude, mesh.field, &worldFromObject[i]).world);
  }
  const int32_t id = takeObjectIds(1);
  const auto lock = changeGeometry();
  auto shared = std::make_shared<Group<double>>();
  addMeshTo(shared->triangles(), vertices, faces, faceCount, material, id, colors, normals);
  for (size_t i = 0; i < count; ++i) {
    const Vec3d color = instanceColors ? vec3At(instanceColors, i) : Vec3d(0);
    m_group.addInstance(worldFromObject[i], inverse(worldFromObject[i]), shared, instanceColors ? &color : nullptr);
  }
  m_colored = m_colored || instanceColors != nullptr;
  noteReach(placed);
  return id;
}

int32_t Scene::addBoxes(const double* lo, const double* hi, const int32_t* materials, size_t count, bool perBox,
                        const Affined* worldFromObject, const CornerValues& colors) {
  requireTransform(worldFromObject);
  for (size_t i = 0; i < count; ++i) {
    const Vec3d a = vec3At(lo, i), b = vec3At(hi, i);
    requireFinite(a, "lo[" + std::to_string(i) + "]");
    requireFinite(b, "hi[" + std::to_string(i) + "]");
    if (!(a.x < b.x && a.y < b.y && a.z < b.z)) {
      fail("lo[" + std::to_string(i) + "] must be < hi[" + std::to_string(i) + "] in every axis");
    }
  }
  const auto field = [](size_t i) { return (i % 2 ? "hi[" : "lo[") + std::to_string(i / 2) + "]"; };
  const auto corner = [&](size_t i) { return vec3At(i % 2 ? hi : lo, i / 2); };
  const size_t farthest = farthestPoint(2 * count, corner, field);
  requireMaterials(materials, count, perBox);
  requireColors(colors.values, count, colorField);
  requirePrimitiveRoom(count);
  const Reach placed = requireReach(count ? maxAbs(corner(farthest)) : 0, field(farthest), worldFromObject);
  const int32_t first = takeObjectIds(count);
  const auto lock = changeGeometry();
  BoxSet<double>& boxes = groupFor(worldFromObject).boxes();
  const bool given = colors.values && count;
  prepareColors(boxes, given);
  for (size_t i = 0; i < count; ++i) {
    addTo(boxes, Box<double>{vec3At(lo, i), vec3At(hi, i)}, materials[perBox ? i : 0], first + static_cast<int32_t>(i),
          given, [&] { return BoxSet<double>::Colors{vec3At(colors.values, i)}; });
  }
  noteReach(placed);
  return first;
}

void Scene::requireMaterials(const int32_t* materials, size_t count, bool perPrimitive) const {
  for (size_t i = 0; i < (perPrimitive ? count : std::min<size_t>(count, 1)); ++i) {
    const int32_t m = materials[i];
    if (m < 0 || static_cast<size_t>(m) >= m_materials.size()) {
      requireMaterial(m, perPrimitive ? ("material[" + std::to_string(i) + "]").c_str() : "material");
    }
  }
}

void Scene::requirePrimitiveRoom(size_t count) const {
  // Packed primitive indices are int32 (RayPacket::prim).
  if (count > static_cast<size_t>(std::numeric_limits<int32_t>::max()) - m_group.primitiveCount()) {
    fail("the scene cannot hold more than 2^31 - 1 primitives");
  }
}

void Scene::requireTransform(const Affined* m, const std::string& field) {
  if (!m) return;
  for (int i = 0; i < 3; ++i) {
    const Vec3d row(m->row[i]);
    if (!(std::isfinite(row.x) && std::isfinite(row.y) && std::isfinite(row.z) && std::isfinite(m->offset[i]))) {
      fail(field + " must be finite");
    }
  }
  if (!isInvertible(*m)) fail(field + " must be invertible (it is singular, or its inverse overflows)");
}

namespace {
// ‖A‖∞, the largest row sum of |A|: |A·p| <= ‖A‖∞·|p| in the largest-component norm.
double rowSumNorm(const Affined& m) {
  return std::fmax(glm::dot(absolute(m.row[0]), Vec3d(1)),
                   std::fmax(glm::dot(absolute(m.row[1]), Vec3d(1)), glm::dot(absolute(m.row[2]), Vec3d(1))));
}
}  // namespace

std::string Scene::widestLimitsNote() {
  std::ostringstream note;
  note << " (precision='" << widestLimits().precision << "'; '" << limitsFor(Precision::Float).precision
       << "': ±" << limitsFor(Precision::Float).coordinate << ")";
  return note.str();
}

Scene::Reach Scene::requireReach(double magnitude, std::string field, const Affined* m) {
  const double limit = widestLimits().coordinate;
  requireWithin(magnitude, limit, field, widestLimitsNote());
  Reach reach{magnitude, std::move(field), magnitude};
  if (m) {
    reach.world = rowSumNorm(*m) * magnitude + maxAbs(m->offset);
    requireWithin(reach.world, limit, "transform applied to " + reach.field, widestLimitsNote());
  }
  return reach;
}

void Scene::noteReach(const Reach& reach) {
  if (reach.magnitude > m_reach.magnitude) m_reach.magnitude = reach.magnitude, m_reach.field = reach.field;
  m_reach.world = std::fmax(m_reach.world, reach.world);
}

void Scene::requireFits(const NumericLimits& limits, double rayReach) const {
  const std::string where = withPrecision(limits.precision);
  const Reach scene = reach();
  requireWithin(scene.magnitude, limits.coordinate, scene.field, where);
  const double world = std::fmax(scene.world, rayReach);
  std::ostringstream field;
  field << "transform: the scene and rays (reaching " << world << ") in its object space";
  for (const Instance<double>& instance : m_group.instances()) {
    const Affined& m = instance.objectFromWorld;
    requireWithin(rowSumNorm(m) * world + maxAbs(m.offset), limits.coordinate, field.str(), where);
  }
}

Group<double>& Scene::groupFor(const Affined* m) {
  if (!m || m->isIdentity()) return m_group;
  return m_group.transformed(*m, inverse(*m));
}

namespace {
void requireAttenuation(const Vec3d& c) {
  requireNonNegativeColor(c, "attenuation");
  if (c.x == 0 && c.y == 0 && c.z == 0) fail("attenuation must not be all zero");
}

void requireSamples(int samples) {
  if (samples < 1 || samples > kRenderLimits.raysPerHit) {
    fail("samples must be in [1, " + std::to_string(kRenderLimits.raysPerHit) + "], got " + std::to_string(samples));
  }
}

// A point or spot light's radius and samples; the field its sphere's reach is checked under.
const char* requireRadius(const SoftShadows& soft) {
  if (!(std::isfinite(soft.size) && soft.size >= 0)) fail("radius must be finite and >= 0, got " + show(soft.size));
  requireSamples(soft.samples);
  return soft.size > 0 ? "position and radius" : "position";
}
}  // namespace

void Scene::addDirectionalLight(const DirectionalLight& light) {
  requireNonZero(light.direction, "direction");
  requireNonNegativeColor(light.color, "color");
  if (!(light.soft.size >= 0 && light.soft.size < kPi / 2)) {
    fail("angle_degrees must be in [0, 180), got " + show(light.soft.size * 360 / kPi));
  }
  requireSamples(light.soft.samples);
  DirectionalLight sun = light;
  sun.direction = safeNormalize(light.direction);
  m_directionalLights.push_back(sun);
}

void Scene::addPointLight(const PointLight& light) {
  requireFinite(light.position, "position");
  const Reach placed = requireReach(maxAbs(light.position) + light.soft.size, requireRadius(light.soft), nullptr);
  requireNonNegativeColor(light.color, "color");
  requireAttenuation(light.attenuation);
  m_pointLights.push_back(light);
  noteReach(placed);
}

void Scene::addSpotLight(const SpotLight& light) {
  requireFinite(light.position, "position");
  const Reach placed = requireReach(maxAbs(light.position) + light.soft.size, requireRadius(light.soft), nullptr);
  requireNonZero(light.direction, "direction");
  requireNonNegativeColor(light.color, "color");
  requireAttenuation(light.attenuation);
  if (!(light.cosHalfAngle > -1 && light.cosHalfAngle < 1)) fail("half_angle_degrees must be in (0, 180)");
  if (!(light.blend >= 0 && light.blend <= 1)) fail("blend must be in [0, 1], got " + show(light.blend));
  SpotLight spot = light;
  spot.direction = safeNormalize(light.direction);
  m_spotLights.push_back(spot);
  noteReach(placed);
}

void Scene::addAreaLight(const AreaLight& light) {
  requireFinite(light.position, "position");
  requireFinite(light.u, "u");
  requireFinite(light.v, "v");
  // Every point of the surface within the coordinate limit (its corners bound it).
  const Reach placed = requireReach(maxAbs(light.position) + (maxAbs(light.u) + maxAbs(light.v)) / 2,
                                    "position, u and v (its corners)", nullptr);
  const Vec3d normal = glm::cross(light.u, light.v);
  if (!(glm::dot(normal, normal) > 0)) fail("u and v must span a surface (neither zero nor parallel)");
  requireNonNegativeColor(light.color, "color");
  requireSamples(light.samples);
  m_areaLights.push_back(light);
  noteReach(placed);
}

void Scene::setBackground(const Vec4d& rgba) {
  requireNonNegativeColor(Vec3d(rgba), "background");
  if (!(std::isfinite(rgba.w) && rgba.w >= 0 && rgba.w <= 1)) fail("background alpha must be in [0, 1]");
  m_background = rgba;
}

void Scene::setAmbient(const Vec3d& rgb) {
  requireNonNegativeColor(rgb, "ambient");
  m_ambient = rgb;
}

}  // namespace durer
