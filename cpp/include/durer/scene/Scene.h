#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "durer/accel/Group.h"
#include "durer/scene/Light.h"
#include "durer/scene/Limits.h"
#include "durer/scene/Material.h"
#include "durer/Options.h"
#include "durer/math/Vec.h"

namespace durer {

struct PlaneBounds {
  Vec3d corner;  // on the plane
  Vec3d edge1;   // in the plane, non-zero
  Vec3d edge2;   // in the plane, not parallel to edge1
};

// Vectors given with a geometry add, or none (null values). Colours: each primitive's kd (linear
// RGB; finite, >= 0, each channel within the colour limit) in place of its material's, lit or flat.
// A mesh's normals: its smooth normals (finite, nonzero, of any length), in object space.
struct CornerValues {
  const double* values = nullptr;
  // Triangles: three per triangle (at v0, v1, v2, interpolated across it) rather than one. A mesh:
  // three per face (its corners) rather than one per vertex (shared by the faces that use it).
  bool perCorner = false;
};

// What is rendered: geometry (kept in double; converted once per render for float precision),
// materials, lights and the background. Every add validates its input and throws
// std::invalid_argument naming the field; an add that throws changes nothing.
class Scene {
 public:
  Scene();  // material 0 is the default material (diffuse 0.8 grey, Blender's default)

  int32_t addMaterial(const Material& material);

  // Every geometry add takes worldFromObject: null (or the identity) puts the objects in world space;
  // an invertible affine map puts them in the transformed group of that map (see Instance in Group.h).
  // Object ids are returned for the first object; the others follow consecutively.

  // Every add but addPlane takes colors (CornerValues): count x 3 doubles (spheres, boxes, triangles),
  // count x 3 x 3 (triangles per corner), vertexCount x 3 or faceCount x 3 x 3 (a mesh).

  // centers: count x 3 doubles; radii: count doubles; materials: count ids, or one id if !perSphere.
  // oneSided, if given: count flags, non-zero for a sphere met from outside only (a ray starting
  // inside it passes through it, as Cycles meets a point cloud's points; see Group::passInsides).
  int32_t addSpheres(const double* centers, const double* radii, const int32_t* materials, size_t count,
                     bool perSphere, const Affined* worldFromObject = nullptr, const CornerValues& colors = {},
                     const uint8_t* oneSided = nullptr);
  // Moves spheres already added (an animation's next frame): ids are object ids addSpheres
  // returned, centers count x 3 doubles, radii count doubles or null to keep the radii. The
  // hierarchies already built are refitted at the next render, not rebuilt (rebuilt where refitting
  // would make them much slower to trace).
  void moveSpheres(const int32_t* ids, const double* centers, const double* radii, size_t count);
  int32_t addPlane(const Vec3d& normal, double offset, int32_t material, const PlaneBounds* bounds,
                   const Affined* worldFromObject = nullptr);
  // vertices: count x 3 x 3 doubles (v0, v1, v2 of each triangle); one object per triangle.
  int32_t addTriangles(const double* vertices, const int32_t* materials, size_t count, bool perTriangle,
                       const Affined* worldFromObject = nullptr, const CornerValues& colors = {});
  // One object: faceCount triangles indexing vertexCount x 3 doubles by 0-based faces (faceCount x 3).
  // `normals`, if given: shaded and written in place of each face's own normal, interpolated across
  // it (a smooth mesh); rays still leave a face, and meet it, by its own normal.
  int32_t addMesh(const double* vertices, size_t vertexCount, const int64_t* faces, size_t faceCount, int32_t material,
                  const Affined* worldFromObject = nullptr, const CornerValues& colors = {},
                  const CornerValues& normals = {});
  // The mesh of addMesh seen through each of `count` transforms (worldFromObject: count maps, each
  // invertible): one object whose triangles and hierarchy are stored once and shared by its
  // instances (Group::addInstance), however many there are. instanceColors (count x 3, or null):
  // each instance's kd, in place of the material's and the mesh's colours.
  int32_t addMeshInstances(const double* vertices, size_t vertexCount, const int64_t* faces, size_t faceCount,
                           int32_t material, const Affined* worldFromObject, size_t count,
                           const CornerValues& colors = {}, const double* instanceColors = nullptr,
                           const CornerValues& normals = {});
  // lo, hi: count x 3 doubles, lo < hi in each axis; one object per box.
  int32_t addBoxes(const double* lo, const double* hi, const int32_t* materials, size_t count, bool perBox,
                   const Affined* worldFromObject = nullptr, const CornerValues& colors = {});
  void addDirectionalLight(const DirectionalLight& light);  // light.direction need not be unit
  void addPointLight(const PointLight& light);
  void addSpotLight(const SpotLight& light);  // light.direction need not be unit
  void addAreaLight(const AreaLight& light);
  // What rays that meet nothing see (RGB), and how much of a pixel whose camera ray meets nothing
  // the background covers (alpha): such a pixel is premultiplied, (r·a, g·a, b·a, a), while rays
  // after a bounce see (r, g, b) whatever a is (a transparent film still reflects the world).
  void setBackground(const Vec4d& rgba);
  void setAmbient(const Vec3d& rgb);
  void setShading(ShadingMode mode) { m_shading = mode; }

  const Group<double>& group() const { return m_group; }
  // How the geometry was made ready for tracing, counted over the scene's life.
  struct HierarchyCounts {
    int64_t built = 0;     // prepared from scratch (a precision's first render, or after an add)
    int64_t refitted = 0;  // made ready after moveSpheres by refitting
    int64_t rebuilt = 0;   // of the sphere hierarchies refitted, those rebuilt as refitting degraded them
    double milliseconds = 0;  // spent on all of it
  };
  HierarchyCounts hierarchyCounts() const;
  // The geometry as traced in precision Real: rounded to it, with its acceleration structure. Built
  // on first use (on `threads` threads, 0: all cores) and kept until the scene changes; safe to call
  // from concurrent renders. hierarchies false: for a caller whose rays never walk the scene's own
  // spheres' hierarchy (a render of camera and shadow rays, which the views serve), made without
  // it, and made again with it when a caller asks for it.
  template <typename Real>
  std::shared_ptr<const Group<Real>> prepared(int threads, bool hierarchies = true) const;
  const std::vector<Material>& materials() const { return m_materials; }
  const std::vector<DirectionalLight>& directionalLights() const { return m_directionalLights; }
  const std::vector<PointLight>& pointLights() const { return m_pointLights; }
  const std::vector<SpotLight>& spotLights() const { return m_spotLights; }
  const std::vector<AreaLight>& areaLights() const { return m_areaLights; }
  ShadingMode shadingMode() const { return m_shading; }
  const Vec4d& background() const { return m_background; }
  const Vec3d& ambient() const { return m_ambient; }
  int32_t objectCount() const { return m_objectCount; }
  // Whether some primitive carries its own colours (then hits are shaded from their hit records).
  bool colored() const { return m_colored; }
  bool hasLights() const {
    return !m_directionalLights.empty() || !m_pointLights.empty() || !m_spotLights.empty() || !m_areaLights.empty();
  }
  // Whether hits are shaded with lights (Lit) or take their flat colour.
  bool lit() const { return m_shading == ShadingMode::Lit || (m_shading == ShadingMode::Auto && hasLights()); }
  // Throws std::invalid_argument naming the field unless every coordinate fits `limits` (the adds
  // checked the widest precision's), and every transform's object space, holding the scene and rays
  // whose origins reach rayReach (largest |coordinate|), does too.
  void requireFits(const NumericLimits& limits, double rayReach) const;
  // " (precision='double'; 'float': ±1e+18)": what an add's coordinate error adds to its message.
  static std::string widestLimitsNote();

 private:
  void requireMaterial(int32_t material, const char* field) const;
  void requireMaterials(const int32_t* materials, size_t count, bool perPrimitive) const;
  void requirePrimitiveRoom(size_t count) const;
  // Adds primitive i of an add to `set` (Set::add's arguments but the colours): with the add's
  // colours, made by colorsOf(), if it has them; with its material's kd if the set is coloured by
  // an earlier add. Call prepareColors first.
  template <typename Set, typename Prim, typename ColorsOf>
  void addTo(Set& set, const Prim& primitive, int32_t material, int32_t objectId, bool given, const ColorsOf& colorsOf);
  // Before an add with colours (`given`) to `set`: the primitives already there take their kd.
  template <typename Set>
  void prepareColors(Set& set, bool given);
  int32_t takeObjectIds(size_t count);
  // The group objects seen through worldFromObject go into (validated first); the world if null or identity.
  Group<double>& groupFor(const Affined* worldFromObject);
  static void requireTransform(const Affined* worldFromObject, const std::string& field = "transform");
  // An add's largest |coordinate| (object space) and the field it came from: checked against the
  // widest limits, in world space too under worldFromObject, before the add changes anything;
  // recorded by noteReach once it has.
  struct Reach {
    double magnitude = 0;  // object space included: what the kernels see
    std::string field;
    double world = 0;      // where it lands in world space
  };
  static Reach requireReach(double magnitude, std::string field, const Affined* worldFromObject);
  void noteReach(const Reach& reach);
  // addMesh's checks of its arguments but the transform; returns the reach of its vertices (object space).
  Reach requireMesh(const double* vertices, size_t vertexCount, const int64_t* faces, size_t faceCount,
                    int32_t material, const CornerValues& colors, const CornerValues& normals) const;
  // The mesh's triangles, object `id`, into `triangles` (the checks passed).
  void addMeshTo(TriangleSet<double>& triangles, const double* vertices, const int64_t* faces, size_t faceCount,
                 int32_t material, int32_t id, const CornerValues& colors, const CornerValues& normals);

  // Drops the prepared geometry and holds the lock while the caller changes m_group.
  std::unique_lock<std::mutex> changeGeometry();

  // Spheres with object ids [firstId, firstId + count) are group's spheres [start, start + count).
  struct SphereRun {
    int32_t firstId;
    size_t count;
    Group<double>* group;
    size_t start;
    bool transformed;         // the group is a transformed one, seen through:
    Affined worldFromObject;
    Reach reach;              // of its spheres where they are now (moveSpheres keeps it so)
    size_t farthest = 0;      // the group's sphere that reach measured
  };
  // Run's reach measured again over all its spheres, after a move took its farthest sphere nearer.
  void measureReach(SphereRun& run);
  // The farthest of every add's reach, the spheres' where they are now.
  Reach reach() const;
  // Geometry as traced in one precision, and whether spheres have moved since it was made.
  template <typename Real>
  struct Prepared {
    std::shared_ptr<Group<Real>> group;
    bool moved = false;
    bool hierarchies = true;  // the scene's own spheres' hierarchy built (Group::prepare)
  };

  Group<double> m_group;
  std::vector<SphereRun> m_sphereRuns;  // by firstId
  mutable std::mutex m_preparedMutex;
  mutable Prepared<float> m_preparedFloat;
  mutable Prepared<double> m_preparedDouble;
  mutable HierarchyCounts m_hierarchyCounts;
  std::vector<Material> m_materials;
  std::vector<DirectionalLight> m_directionalLights;
  std::vector<PointLight> m_pointLights;
  std::vector<SpotLight> m_spotLights;
  std::vector<AreaLight> m_areaLights;
  ShadingMode m_shading = ShadingMode::Auto;
  Vec4d m_background{0, 0, 0, 1};
  Vec3d m_ambient{0};
  int32_t m_objectCount = 0;
  bool m_colored = false;
  Reach m_reach;  // the largest of every add's but spheres' (world: the largest world reach): m_sphereRuns hold theirs
};

}  // namespace durer
