"""Blender's evaluated depsgraph -> plain numpy data (`SceneData`) that Dürer can render.

Nothing here calls the renderer, so tests can inspect exactly what a Blender scene turns into.
Conventions (verified against Cycles in bpy 5.0.1, see docs/blender.md):

* Geometry comes from ``depsgraph.object_instances`` (geometry-nodes and collection instances
  count). Point clouds become one sphere per point (bulk ``foreach_get``, no per-point Python);
  meshes whose vertices all lie on one sphere become that sphere; empties displayed as spheres and
  metaball balls become spheres; flat quad meshes become bounded planes; every other mesh, curve,
  text and surface becomes triangles (its loop triangles, one Dürer mesh per material slot used,
  in object space with the object's matrix). ``object.durer.primitive`` overrides the detection
  (Auto / Sphere / Plane / Mesh / Ignore); what Dürer cannot render (volumes, hair curves and hair particle systems, grease
  pencil, metaball capsules) is skipped and counted.
* Spheres under a uniform scale are exported in world space; under a non-uniform scale or a
  shear they keep their object-space centre and radius with the object's matrix, which the core
  renders exactly as an ellipsoid.
* Lights are radiometric as in Cycles (see `lights`). Materials become 6.837 materials (see
  `materials.material_data`): ``material.durer`` states one exactly; else Principled metallic and
  specular reflectance make a Phong highlight of the lobe's width and peak, and a mirror as well
  at roughness <= MIRROR_ROUGHNESS (the highlight then the lights' glint), transmission makes a
  transparent colour with the IOR. Light "Cast Shadow"
  -> shadows.
* The camera keeps Blender's parameters (fit, shift in units of the fitted extent, clip range,
  pixel aspect) and the resolved image size.

Modules: `depsgraph` (the walk; a converter per object type), `builder` (collects a `SceneData`),
`data` (the plain data classes), `shapes` (sphere and plane detection), `triangles` (a mesh's
loop triangles per material slot), `materials` (a converter per shader node), `lights` (one per
light type), `world`, `camera`, `matrices` and `nodes` (socket values).
"""

from __future__ import annotations

from .camera import camera_data, lens_data
from .data import (
    CameraData,
    LensData,
    LightData,
    MaterialData,
    MeshData,
    PlaneData,
    SceneData,
    TransformedSpheres,
)
from .depsgraph import export_depsgraph
from .materials import material_data
from .world import world_colors

__all__ = [
    "CameraData",
    "LensData",
    "LightData",
    "MaterialData",
    "MeshData",
    "PlaneData",
    "SceneData",
    "TransformedSpheres",
    "camera_data",
    "export_depsgraph",
    "lens_data",
    "material_data",
    "world_colors",
]
