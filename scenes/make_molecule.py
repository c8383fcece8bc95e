"""Build scenes/molecule.blend: a synthetic protein as one point cloud of atoms coloured by element,
lit by a sun casting shadows and by the world's ambient light with ambient occlusion (issue 14's
molecule showcase).

The protein is made from a seed, nothing is downloaded: a backbone of residues whose alpha carbons
follow a (mostly) self-avoiding random walk of 3.8 Å steps held in a globule, each residue's N, C and O
around its alpha carbon, a side chain of 0-4 heavy atoms pointing away from the globule's centre
(mostly carbon, ending in N, O or S as lysine, serine or cysteine do), and hydrogens on the
carbons and nitrogens. Elements C, N, O, S, H with their van der Waals radii (space-filling) and CPK
colours (C grey, N blue, O red, S yellow, H white); 1 Å is 0.1 Blender units.

The atoms are one object made the way molecular add-ons (e.g. Molecular Nodes) make one: a mesh of
loose vertices carrying per-atom attributes (`element`, the atomic number; `radius`; `Color`,
FLOAT_COLOR) through a geometry-nodes modifier (Mesh to Points with the `radius` attribute as the
radius, Set Material); the material's Base Color is an Attribute node reading `Color`. A ground
plane (a quad Dürer renders as an infinite plane) catches the shadow; the world lights the scene
with Cycles' Fast GI Approximation on and an AO distance of 1 (10 Å), which Dürer reads as
ambient occlusion (scene.durer's "From Fast GI" and "World AO Distance", its defaults).

    python scenes/make_molecule.py [OUTPUT.blend] [--residues 300] [--seed 14]   # needs bpy + durer
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import bpy
import durer.blender
import numpy as np
from durer.blender.point_cloud import vertex_object
from mathutils import Vector

HERE = Path(__file__).resolve().parent
RESIDUES = 300
SEED = 14
ANGSTROM = 0.1  # Blender units per ångström
#: Element symbol -> (atomic number, van der Waals radius in Å (Bondi), CPK colour in linear RGB).
ELEMENTS = {
    "C": (6, 1.70, (0.30, 0.30, 0.30)),
    "N": (7, 1.55, (0.05, 0.12, 0.90)),
    "O": (8, 1.52, (0.90, 0.03, 0.02)),
    "S": (16, 1.80, (0.95, 0.80, 0.10)),
    "H": (1, 1.10, (0.85, 0.85, 0.85)),
}
CA_STEP = 3.8  # Å between consecutive alpha carbons
#: How a side chain ends: a carbon mostly, else the heteroatom of lysine/arginine, serine/aspartate or
#: cysteine/methionine.
SIDE_CHAIN_END = (("C", 0.55), ("N", 0.17), ("O", 0.23), ("S", 0.05))
HYDROGENS = {"C": 2, "N": 1, "O": 0, "S": 0}  # on a side chain's atoms; the backbone's CA and N carry one

AMBIENT = (0.30, 0.32, 0.36)
GROUND = (0.8, 0.78, 0.74)
SUN_STRENGTH = 2.0  # irradiance: a white diffuse surface facing the sun is 2/pi
SUN_TRAVEL = (0.6, 0.5, -1.0)  # the way the light travels: from the camera's upper left
CAMERA_FROM = (0.35, -1.0, 0.6)  # where the camera sits, seen from the molecule's centre
AO_DISTANCE = 1.0  # Blender units: 10 Å, a few atoms deep


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_units(rng: np.random.Generator, n: int) -> np.ndarray:
    return unit(rng.normal(size=(n, 3)))


def alpha_carbons(rng: np.random.Generator, residues: int) -> np.ndarray:
    """(residues, 3) Å: a random walk of CA_STEP steps that keeps its direction a little, is pulled
    back towards the origin beyond half a protein's radius of gyration and draws a step again, up to
    50 times, while it would come within 4 Å of an earlier alpha carbon (where the walk is boxed in,
    the last draw stands: 26 pairs of the default 300 end closer)."""
    gyration = 2.2 * residues**0.38  # Å, the radius of gyration of globular proteins
    ca = np.zeros((residues, 3))
    heading = random_units(rng, 1)[0]
    for i in range(1, residues):
        pull = -ca[i - 1] / gyration * max(np.linalg.norm(ca[i - 1]) / gyration - 0.5, 0.0)
        for _ in range(50):
            step = unit(0.8 * heading + random_units(rng, 1)[0] + pull)
            candidate = ca[i - 1] + CA_STEP * step
            if np.min(np.linalg.norm(ca[: i - 1] - candidate, axis=1), initial=np.inf) >= 4.0:
                break
        ca[i], heading = candidate, step
    return ca


def molecule(residues: int = RESIDUES, seed: int = SEED) -> tuple[np.ndarray, list[str]]:
    """The atoms' centres ((N, 3), Blender units, z up, the lowest atom's surface 2 Å above z = 0
    and the atoms' mean over the origin) and their element symbols."""
    rng = np.random.default_rng(seed)
    ca = alpha_carbons(rng, residues)
    centre = ca.mean(axis=0)
    positions: list[np.ndarray] = []
    elements: list[str] = []
    ends, end_weights = zip(*SIDE_CHAIN_END)

    def atom(element: str, at: np.ndarray) -> np.ndarray:
        positions.append(at)
        elements.append(element)
        return at

    def hydrogens(at: np.ndarray, away: np.ndarray, count: int) -> None:
        for direction in random_units(rng, count):
            atom("H", at + 1.05 * unit(direction + 1.2 * away))

    for i in range(residues):
        tangent = unit(ca[min(i + 1, residues - 1)] - ca[max(i - 1, 0)])
        outward = unit(ca[i] - centre + 2.0 * rng.normal(size=3))
        side = unit(outward - np.dot(outward, tangent) * tangent)
        across = np.cross(tangent, side)
        atom("C", ca[i])  # the alpha carbon
        hydrogens(ca[i], -side, 1)
        n = atom("N", ca[i] + 1.46 * unit(-tangent - 0.4 * side + 0.3 * across))
        hydrogens(n, unit(-tangent - 0.3 * across), 1)
        c = atom("C", ca[i] + 1.52 * unit(tangent - 0.4 * side - 0.3 * across))
        atom("O", c + 1.23 * unit(-side + 0.5 * across))
        length = rng.choice(5, p=(0.1, 0.25, 0.3, 0.2, 0.15))
        at = ca[i]
        for k in range(length):
            zigzag = across * (0.5 if k % 2 else -0.5) + 0.3 * rng.normal(size=3)
            at = at + 1.53 * unit(side + zigzag)
            element = str(rng.choice(ends, p=end_weights)) if k == length - 1 else "C"
            atom(element, at)
            hydrogens(at, side, HYDROGENS[element])
    atoms = np.array(positions) * ANGSTROM
    radii = atom_table(elements)[1]
    atoms -= (*atoms[:, :2].mean(axis=0), np.min(atoms[:, 2] - radii) - 2.0 * ANGSTROM)
    return atoms, elements


def atom_table(elements: Sequence[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per atom: the atomic number (int32), the radius in Blender units and the RGBA colour (float32)."""
    numbers, radii, colors = zip(*(ELEMENTS[e] for e in elements))
    rgba = np.column_stack([np.array(colors), np.ones(len(elements))])
    return np.array(numbers, np.int32), np.array(radii, np.float32) * ANGSTROM, rgba.astype(np.float32)


def atom_material() -> bpy.types.Material:
    """A slightly glossy Principled BSDF whose Base Color is the point's `Color` attribute."""
    mat = bpy.data.materials.new("Atoms")
    tree = mat.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = 0.5
    bsdf.inputs["Specular IOR Level"].default_value = 0.5
    attribute = tree.nodes.new("ShaderNodeAttribute")
    attribute.attribute_name = "Color"
    tree.links.new(attribute.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def atoms_object(collection: bpy.types.Collection, positions: np.ndarray, elements: Sequence[str]) -> bpy.types.Object:
    """The atoms as one vertex mesh with `element`, `radius` and `Color` point attributes, turned
    into spheres by a geometry-nodes modifier: Mesh to Points (radius: the attribute), Set Material."""
    obj = vertex_object(collection, "Protein", positions)
    numbers, radii, colors = atom_table(elements)
    attributes = obj.data.attributes
    attributes.new("element", "INT", "POINT").data.foreach_set("value", numbers)
    attributes.new("radius", "FLOAT", "POINT").data.foreach_set("value", radii)
    attributes.new("Color", "FLOAT_COLOR", "POINT").data.foreach_set("color", colors.ravel())

    group = bpy.data.node_groups.new("Atoms as spheres", "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = group.nodes, group.links
    to_points, radius = nodes.new("GeometryNodeMeshToPoints"), nodes.new("GeometryNodeInputNamedAttribute")
    radius.data_type = "FLOAT"
    radius.inputs["Name"].default_value = "radius"
    set_material = nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = atom_material()
    links.new(nodes.new("NodeGroupInput").outputs[0], to_points.inputs["Mesh"])
    links.new(radius.outputs["Attribute"], to_points.inputs["Radius"])
    links.new(to_points.outputs[0], set_material.inputs["Geometry"])
    links.new(set_material.outputs[0], nodes.new("NodeGroupOutput").inputs[0])
    obj.modifiers.new("Atoms", "NODES").node_group = group
    return obj


def aimed(obj: bpy.types.Object, direction) -> bpy.types.Object:
    """`obj` turned so that its -Z axis (where cameras look and lights shine) points along `direction`."""
    obj.rotation_euler = Vector(direction).to_track_quat("-Z", "Y").to_euler()
    return obj


def build(residues: int = RESIDUES, seed: int = SEED) -> bpy.types.Scene:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    durer.blender.register()
    scene = bpy.context.scene
    scene.name = "Molecule"
    coll = scene.collection

    world = bpy.data.worlds.new("Sky")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*AMBIENT, 1.0)
    world.color = AMBIENT
    world.light_settings.distance = AO_DISTANCE
    scene.world = world
    scene.cycles.use_fast_gi = True  # Dürer's ambient occlusion "From Fast GI" follows it

    ground_mat = bpy.data.materials.new("Ground")
    bsdf = ground_mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*GROUND, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    mesh = bpy.data.meshes.new("Ground")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(ground_mat)
    ground = bpy.data.objects.new("Ground", mesh)
    ground.scale = (100, 100, 1)  # Cycles' quad fills the view as Dürer's infinite plane does
    ground.durer.infinite_plane = True
    coll.objects.link(ground)

    positions, elements = molecule(residues, seed)
    atoms_object(coll, positions, elements)

    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy = SUN_STRENGTH
    sun.angle = 0.0  # a point-like sun: hard shadows, as Dürer's
    sun.use_shadow = True
    sun_obj = aimed(bpy.data.objects.new("Sun", sun), SUN_TRAVEL)
    sun_obj.location = (0, 0, 10)
    coll.objects.link(sun_obj)

    # A 50 mm lens aimed a little below the molecule's centre and towards its shadow, at a distance
    # that fits the molecule's bounding sphere into the 16:9 frame's height with room for the shadow.
    centre = positions.mean(axis=0)
    extent = np.max(np.linalg.norm(positions - centre, axis=1)) + 0.2
    shadow = centre[2] / -SUN_TRAVEL[2] * np.array(SUN_TRAVEL)  # from the centre to its shadow
    target = Vector(centre + 0.4 * shadow * (1.0, 1.0, 0.5))
    camera = bpy.data.cameras.new("Camera")
    camera.lens, camera.sensor_width = 50.0, 36.0
    half_height = 18.0 * 9 / 16 / 50.0  # tan of half the vertical field of view
    direction = Vector(CAMERA_FROM).normalized()
    camera_obj = aimed(bpy.data.objects.new("Camera", camera), -direction)
    camera_obj.location = target + direction * (1.25 * extent / half_height)
    camera.clip_start, camera.clip_end = 0.1, 200.0
    coll.objects.link(camera_obj)
    scene.camera = camera_obj

    scene.render.engine = "DURER"
    scene.render.resolution_x, scene.render.resolution_y = 960, 540
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.view_settings.view_transform = "Standard"  # plain sRGB, like durer.save_image
    scene.durer.samples = 4
    scene.cycles.samples = 256
    scene.frame_start = scene.frame_end = scene.frame_current = 1
    return scene


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", nargs="?", type=Path, default=HERE / "molecule.blend")
    parser.add_argument("--residues", type=int, default=RESIDUES)
    parser.add_argument("--seed", type=int, default=SEED)
    args = parser.parse_args(argv)
    build(args.residues, args.seed)
    bpy.ops.wm.save_as_mainfile(filepath=str(args.output.resolve()), compress=True)
    print(args.output.resolve())
    return 0


if __name__ == "__main__":
    sys.exit(main())
