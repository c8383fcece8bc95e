"""Dürer against Cycles (both inside the same bpy): camera geometry (hit masks, Depth, Normal)
and brightness (Combined under Sun and Point lights)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers.blender import (
    MISS,
    aim_camera,
    both,
    compare_shading,
    cube,
    export,
    grid,
    light,
    material,
    pointcloud_object,
    quad,
    render_passes,
    smooth_mask,
    use_cycles,
    uv_sphere,
    vertex_object,
    world,
)

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

pytestmark = pytest.mark.blender


def build_scene(s, plane_material=None, sphere_material=None):
    """Point-cloud spheres of several sizes above a bounded plane, black world."""
    world(s, (0, 0, 0))
    rng = np.random.default_rng(3)
    n = 24
    centers = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(-0.5, 1.5, n)])
    radii = rng.uniform(0.2, 0.7, n)
    cloud = pointcloud_object(s, "Spheres", centers, radius=radii)
    cloud.data.materials.append(sphere_material or material("Spheres", (0.8, 0.8, 0.8)))
    floor = quad(s, "Floor", location=(0, 0, -1.0), scale=(5, 4, 1))
    floor.data.materials.append(plane_material or material("Floor", (0.8, 0.8, 0.8)))
    return cloud, floor


CAMERA_CASES = [
    # projection, sensor_fit, resolution, percentage, shift
    ("PERSP", "AUTO", (80, 50), 100, (0.0, 0.0)),
    ("PERSP", "AUTO", (50, 80), 100, (0.1, -0.05)),
    ("PERSP", "HORIZONTAL", (60, 90), 50, (0.0, 0.1)),
    ("PERSP", "VERTICAL", (96, 60), 50, (-0.1, 0.05)),
    ("PERSP", "VERTICAL", (50, 70), 100, (0.0, 0.0)),
    ("ORTHO", "AUTO", (80, 50), 100, (0.05, 0.0)),
    ("ORTHO", "AUTO", (50, 80), 100, (0.0, 0.0)),
    ("ORTHO", "HORIZONTAL", (60, 90), 50, (0.1, -0.1)),
    ("ORTHO", "VERTICAL", (96, 60), 50, (0.0, 0.0)),
]


@pytest.mark.parametrize("projection, fit, res, pct, shift", CAMERA_CASES)
def test_masks_depth_normals_match_cycles(scene, tmp_path, projection, fit, res, pct, shift):
    build_scene(scene)
    cam = aim_camera(scene, (6, -8, 5)).data
    cam.type = projection
    cam.sensor_fit = fit
    cam.lens, cam.sensor_width, cam.sensor_height = 40.0, 36.0, 24.0
    cam.ortho_scale = 9.0
    cam.shift_x, cam.shift_y = shift
    cam.clip_start, cam.clip_end = 0.1, 100.0
    scene.render.resolution_x, scene.render.resolution_y = res
    scene.render.resolution_percentage = pct
    light(scene, "SUN", energy=2.0, rotation=(0.4, 0.3, 0))
    c, d = both(scene, tmp_path)
    h, w = res[1] * pct // 100, res[0] * pct // 100
    assert c["depth"].shape == d["depth"].shape == (h, w)
    hit_c, hit_d = c["depth"] < MISS, d["depth"] < MISS
    assert 0.2 < hit_c.mean() < 0.95, "the scene should fill part of the image"
    agree = (hit_c == hit_d).mean()
    assert agree >= 0.995, f"hit masks agree on {agree:.4%} of pixels"
    hit = hit_c & hit_d
    rel = np.abs(d["depth"][hit] - c["depth"][hit]) / c["depth"][hit]
    assert rel.max() <= 1e-4, f"depth: max relative error {rel.max():.2e}"  # measured: <= 3.4e-6
    dn = np.linalg.norm(d["normal"][hit] - c["normal"][hit], axis=1)
    assert dn.max() <= 1e-3, f"normals: max error {dn.max():.2e}"  # measured: <= 8e-5
    # Misses: Combined alpha 1 with the black world on both.
    np.testing.assert_allclose(d["color"][..., 3], 1.0)
    np.testing.assert_allclose(c["color"][..., 3], 1.0)
    miss = ~hit_c & ~hit_d
    assert miss.any()
    np.testing.assert_array_equal(d["color"][miss][:, :3], 0.0)
    np.testing.assert_array_equal(c["color"][miss][:, :3], 0.0)


def shading_scene(s):
    build_scene(s, material("Floor", (0.7, 0.7, 0.7)), material("Spheres", (0.9, 0.5, 0.2)))
    cam = aim_camera(s, (0, -10, 9)).data
    cam.type = "ORTHO"
    cam.ortho_scale = 9.0
    s.render.resolution_x, s.render.resolution_y = 80, 60


def test_sun_brightness_matches_cycles_on_lit_pixels(scene, tmp_path):
    shading_scene(scene)
    light(scene, "SUN", energy=2.5, color=(1.0, 0.9, 0.8), rotation=(0.5, 0.2, 0.3), angle=0.0)
    c, d = both(scene, tmp_path, normal=False)
    compare_shading(c, d)


def test_sun_shadows_match_cycles(scene, tmp_path):
    shading_scene(scene)
    light(scene, "SUN", energy=2.5, color=(1.0, 0.9, 0.8), rotation=(0.5, 0.2, 0.3), angle=0.0)
    c, d = both(scene, tmp_path, normal=False)
    mask = compare_shading(c, d, lit_only=False)
    shadowed = mask & (c["color"][..., :3].mean(axis=-1) < 1e-3)  # the black world lights nothing there
    assert shadowed.sum() >= 50, "the compared pixels should include shadows"


def test_point_light_brightness_matches_cycles(scene, tmp_path):
    shading_scene(scene)
    light(scene, "POINT", energy=400.0, location=(1, -2, 4), shadow_soft_size=0.0)
    c, d = both(scene, tmp_path, normal=False)
    compare_shading(c, d)


def test_geometry_without_a_material_is_cycles_default_surface(scene, tmp_path):
    """No material: Cycles' default surface (a Principled BSDF of its defaults), not the object's
    viewport colour."""
    shading_scene(scene)
    for obj in (scene.objects["Spheres"], scene.objects["Floor"]):
        obj.data.materials.clear()
        obj.color = (0.2, 0.9, 0.3, 1.0)
    light(scene, "SUN", energy=2.5, rotation=(0.5, 0.2, 0.3), angle=0.0)
    c, d = both(scene, tmp_path, normal=False)
    mask = smooth_mask(c["color"], d["depth"] < MISS, c["depth"] < MISS)
    assert mask.mean() > 0.3
    ratio = d["color"][mask][:, :3] / c["color"][mask][:, :3]
    # Measured: median 1.0024; up to 1.048 in the highlights (a Phong lobe for Cycles' microfacet one).
    assert abs(np.median(ratio) - 1) < 0.01 and np.abs(ratio - 1).max() < 0.06


def test_points_and_vertices_not_finite_are_left_out_as_cycles_does(scene, tmp_path):
    """A NaN and an inf position and an inf radius in a point cloud, a NaN vertex of a grid, spheres
    and cubes instanced on vertices one of which is NaN: Cycles leaves those out and renders the
    rest; so does Dürer (it refused the whole scene before), saying what it left out."""
    from durer.blender.point_cloud import instance_on_points

    shading_scene(scene)
    light(scene, "SUN", energy=2.5, rotation=(0.5, 0.2, 0.3), angle=0.0)
    points = scene.objects["Spheres"].data
    positions = np.empty(3 * len(points.points), np.float32)
    points.attributes["position"].data.foreach_get("vector", positions)
    positions[0], positions[4] = np.nan, np.inf
    points.attributes["position"].data.foreach_set("vector", positions)
    radii = np.empty(len(points.points), np.float32)
    points.attributes["radius"].data.foreach_get("value", radii)
    radii[2] = np.inf
    points.attributes["radius"].data.foreach_set("value", radii)
    sheet = grid(scene, "Sheet", size=1.0, n=4, location=(2.0, 1.0, 2.0))
    sheet.data.vertices[5].co = (np.nan, 0.0, 0.0)
    for name, instanced, x in (("Balls", uv_sphere(scene, "Ball", radius=0.3), -3.0),
                               ("Boxes", cube(scene, "Box", size=0.5), 3.0)):
        instanced.location = (0.0, 0.0, 50.0)  # out of sight
        host = vertex_object(scene, name, [(x, -2.0, 1.0), (np.nan, 0.0, 0.0), (x, 0.0, 1.0)])
        instance_on_points(host, instanced, rotate=False)
    c, d = both(scene, tmp_path, normal=False)
    hit_c, hit_d = c["depth"] < MISS, d["depth"] < MISS
    assert (hit_c == hit_d).mean() >= 0.995 and hit_c.mean() > 0.3
    compare_shading(c, d)
    notes = export(scene).warnings
    assert "Dürer left out 3 sphere(s) of 'Spheres' whose position or radius is not finite, as Cycles does" in notes
    assert "Dürer left out 1 sphere(s) of 'Balls' whose position or radius is not finite, as Cycles does" in notes
    sheet.data.calc_loop_triangles()
    faces = sum(5 in t.vertices[:] for t in sheet.data.loop_triangles)
    assert f"Dürer left out {faces} face(s) of 'Sheet' with a vertex that is not finite, as Cycles does" in notes
    assert any(n.startswith("Dürer left out 'Boxes'") for n in notes)


def test_emission_is_colour_times_strength(scene, tmp_path):
    world(scene, (0, 0, 0))
    cloud = pointcloud_object(scene, "Glow", [(0, 0, 0)], radius=1.0)
    cloud.data.materials.append(material("Glow", emission=((1.0, 0.5, 0.25), 2.0)))
    cam = aim_camera(scene, (0, -10, 0)).data
    cam.type = "ORTHO"
    cam.ortho_scale = 4.0
    c, d = both(scene, tmp_path, normal=False)
    centre = d["color"][24, 32, :3]
    np.testing.assert_allclose(centre, [2.0, 1.0, 0.5], rtol=1e-4)
    np.testing.assert_allclose(c["color"][24, 32, :3], [2.0, 1.0, 0.5], rtol=1e-3)
    assert math.isclose(d["color"][0, 0, 3], 1.0)


@pytest.mark.parametrize("camera_z, sun_x_rotation", [(-5, math.pi), (-5, 0.0), (5, 0.0), (5, math.pi)])
@pytest.mark.parametrize("projection", ["PERSP", "ORTHO"])
def test_both_sides_of_a_plane_like_cycles(scene, tmp_path, camera_z, sun_x_rotation, projection):
    """Cycles lights whichever side of a face the light is on and writes the normal of the side
    the camera sees."""
    world(scene, (0, 0, 0))
    floor = quad(scene, "Sheet", scale=(5, 5, 1), location=(0, 0, 0.25))
    floor.data.materials.append(material("White", (1, 1, 1)))
    scene.render.resolution_x, scene.render.resolution_y = 8, 8
    aim_camera(scene, (0, 0.01, camera_z)).data.type = projection
    light(scene, "SUN", energy=1.0, rotation=(sun_x_rotation, 0.3, 0), angle=0.0)
    c, d = both(scene, tmp_path)
    np.testing.assert_allclose(d["normal"], c["normal"], atol=1e-6)
    np.testing.assert_allclose(d["color"], c["color"], rtol=1e-5, atol=1e-6)


def test_ground_plane_at_zero_is_lit_like_cycles(scene, tmp_path):
    world(scene, (0, 0, 0))
    quad(scene, "Ground", scale=(5, 5, 1)).data.materials.append(material("White", (1, 1, 1)))
    scene.render.resolution_x, scene.render.resolution_y = 8, 8
    aim_camera(scene, (0, 0.01, 5))
    light(scene, "SUN", energy=1.0, rotation=(0.2, 0.3, 0), angle=0.0)
    c, d = both(scene, tmp_path)
    np.testing.assert_allclose(d["color"], c["color"], rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("crop", [False, True])
def test_render_region_like_cycles(scene, tmp_path, crop):
    build_scene(scene)
    aim_camera(scene, (6, -8, 5))
    scene.render.resolution_x, scene.render.resolution_y = 63, 47
    r = scene.render
    r.use_border, r.use_crop_to_border = True, crop
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.13, 0.71, 0.27, 0.88
    c, d = both(scene, tmp_path)
    assert c["depth"].shape == d["depth"].shape
    if crop:
        assert c["depth"].shape == (
            int(np.float32(0.88) * 47) - int(np.float32(0.27) * 47),
            int(np.float32(0.71) * 63) - int(np.float32(0.13) * 63),
        )
    hit_c, hit_d = c["depth"] < MISS, d["depth"] < MISS
    assert hit_c.any() and np.array_equal(hit_c, hit_d)
    np.testing.assert_allclose(d["depth"][hit_c], c["depth"][hit_c], rtol=1e-4)
    # The Image datablock holds what the saved file holds (without crop: the region in the whole
    # frame; it held the region alone), bottom row first.
    image = bpy.data.images["Dürer Render"]
    assert tuple(image.size) == d["color"].shape[1::-1]
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    np.testing.assert_allclose(pixels.reshape(d["color"].shape)[::-1], d["color"], atol=1e-6)


def test_spot_light_brightness_matches_cycles(scene, tmp_path):
    shading_scene(scene)
    light(
        scene,
        "SPOT",
        energy=800.0,
        location=(0.5, -1, 5),
        shadow_soft_size=0.0,
        spot_size=math.radians(100),
        spot_blend=0.3,
    )
    c, d = both(scene, tmp_path, normal=False)
    compare_shading(c, d, min_fraction=0.15)  # the cone edge is excluded as a brightness step


def test_transparent_film_like_cycles(scene, tmp_path):
    build_scene(scene)
    aim_camera(scene, (6, -8, 5))
    scene.render.resolution_x, scene.render.resolution_y = 40, 30
    world(scene, (0.3, 0.4, 0.5))
    scene.render.film_transparent = True
    light(scene, "SUN", energy=2.0, rotation=(0.4, 0.3, 0), angle=0.0)
    c, d = both(scene, tmp_path, normal=False)
    miss = c["depth"] >= MISS
    assert miss.any()
    np.testing.assert_array_equal(d["color"][miss], 0.0)
    np.testing.assert_array_equal(c["color"][miss], 0.0)
    np.testing.assert_array_equal(d["color"][~miss][:, 3], 1.0)


def test_a_transparent_film_still_shows_the_world_in_mirrors_like_cycles(scene, tmp_path):
    """A mirror ball under a grey world with Film › Transparent: no world behind it (alpha 0), the
    world in it, as Cycles draws it (one bounce each)."""
    from helpers.blender import uv_sphere

    world(scene, (0.5, 0.5, 0.5))
    scene.render.film_transparent = True
    mirror = material("Mirror", (0.8, 0.8, 0.8), roughness=0.0)
    mirror.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 1.0
    uv_sphere(scene, "Ball", radius=1.0).data.materials.append(mirror)
    cam = aim_camera(scene, (0, -6, 0)).data
    cam.type, cam.ortho_scale = "ORTHO", 3.0
    scene.render.resolution_x, scene.render.resolution_y = 32, 32
    use_cycles(scene, max_bounces=1)
    c = render_passes(scene, tmp_path / "cycles.exr", normal=False)
    scene.render.engine, scene.durer.max_bounces = "DURER", 1
    d = render_passes(scene, tmp_path / "durer.exr", normal=False)
    centre = (slice(12, 20), slice(12, 20))
    np.testing.assert_allclose(c["color"][centre], np.broadcast_to([0.4, 0.4, 0.4, 1.0], (8, 8, 4)), atol=0.01)
    np.testing.assert_allclose(d["color"][centre], np.broadcast_to([0.4, 0.4, 0.4, 1.0], (8, 8, 4)), atol=1e-3)
    miss = c["depth"] >= MISS
    assert miss.sum() > 200
    np.testing.assert_array_equal(d["color"][miss], 0.0)


@pytest.mark.parametrize("projection", ["PERSP", "ORTHO"])
@pytest.mark.parametrize("fit", ["AUTO", "HORIZONTAL", "VERTICAL"])
@pytest.mark.parametrize("aspect", [(2, 1), (1, 3)])
def test_pixel_aspect_like_cycles(scene, tmp_path, projection, fit, aspect):
    """Blender cannot write multilayer EXRs with a pixel aspect (5.0.1), so compare Combined RGBA
    with a transparent film: alpha is the hit mask."""
    build_scene(scene)
    cam = aim_camera(scene, (6, -8, 5)).data
    cam.type, cam.sensor_fit, cam.ortho_scale = projection, fit, 9.0
    cam.shift_x = 0.05
    scene.render.resolution_x, scene.render.resolution_y = 60, 44
    scene.render.pixel_aspect_x, scene.render.pixel_aspect_y = aspect
    scene.render.film_transparent = True
    light(scene, "SUN", energy=2.0, rotation=(0.4, 0.3, 0), angle=0.0)
    st = scene.render.image_settings
    st.media_type, st.file_format, st.exr_codec, st.color_depth, st.color_mode = (
        "IMAGE",
        "OPEN_EXR",
        "NONE",
        "32",
        "RGBA",
    )
    scene.view_settings.view_transform = "Standard"
    images = {}
    for engine_name in ("CYCLES", "DURER"):
        if engine_name == "CYCLES":
            use_cycles(scene)
        else:
            scene.render.engine = "DURER"
        scene.render.filepath = str(tmp_path / f"{engine_name}.exr")
        scene.render.use_file_extension = False
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        from helpers.exr import read_exr

        ch = read_exr(tmp_path / f"{engine_name}.exr")
        images[engine_name] = np.stack([ch[k] for k in "RGBA"], axis=-1)
    c, d = images["CYCLES"], images["DURER"]
    assert c.shape == d.shape == (44, 60, 4)
    hit_c, hit_d = c[..., 3] > 0.5, d[..., 3] > 0.5
    assert 0.1 < hit_c.mean() < 0.95
    assert (hit_c == hit_d).mean() >= 0.995
    both_hit = hit_c & hit_d
    np.testing.assert_allclose(d[both_hit][:, :3], c[both_hit][:, :3], rtol=1e-3, atol=1e-4)


def test_particles_on_an_emitter_hidden_in_renders_like_cycles(scene, tmp_path):
    """Spheres scattered by a particle system over an emitter whose "Show Emitter" is off for
    renders (on in the viewport, as users leave it to place the particles): F12 shows the
    particles where Cycles does and no emitter, depth for depth."""
    from helpers.blender import grid, uv_sphere

    world(scene, (0, 0, 0))
    emitter = grid(scene, "Emitter", size=3.0, n=6)
    emitter.data.materials.append(material("Ground", (0.8, 0.8, 0.8)))
    emitter.show_instancer_for_render, emitter.show_instancer_for_viewport = False, True
    ball = uv_sphere(scene, "Ball", radius=0.15, location=(0, 0, -20))
    ball.data.materials.append(material("Ball", (0.9, 0.4, 0.1)))
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    part = emitter.particle_systems[0].settings
    part.count, part.frame_start, part.frame_end, part.physics_type = 150, 1, 1, "NO"
    part.render_type, part.instance_object, part.particle_size, part.size_random = "OBJECT", ball, 1.0, 0.5
    scene.frame_set(1)
    cam = aim_camera(scene, (0, -0.01, 12)).data
    cam.type, cam.ortho_scale = "ORTHO", 7.0
    scene.render.resolution_x, scene.render.resolution_y = 80, 80
    light(scene, "SUN", energy=2.0, rotation=(0.3, 0.2, 0))
    c, d = both(scene, tmp_path, normal=False)
    hit_c, hit_d = c["depth"] < MISS, d["depth"] < MISS
    assert 0.05 < hit_c.mean() < 0.6, "the particles cover part of the image and the emitter none"
    assert (hit_c == hit_d).mean() >= 0.99, f"hit masks agree on {(hit_c == hit_d).mean():.4%} of pixels"
    hit = hit_c & hit_d
    # Cycles renders the UV sphere's facets, Dürer the sphere they approximate: they part by up to
    # ~0.005 of the radius inside, more where a ray grazes (measured: median 1.0e-3, max 1.2e-2).
    error = np.abs(d["depth"][hit] - c["depth"][hit])
    assert np.median(error) <= 2e-3 and error.max() <= 0.03


@pytest.mark.parametrize("wall, clip", [(9.5, (0.1, 10.0)), (0.5, (0.55, 100.0))])
def test_perspective_clip_range_is_two_planes_as_in_cycles(scene, tmp_path, wall, clip):
    """A wide lens before a wall across the view: Cycles clips at planes along the view axis, so a
    wall at view depth 9.5 is whole under clip_end 10 (its corners 16 away along their rays) and
    one at 0.5 gone with clip_start 0.55 (Dürer, clipping along the rays, hit 11 % and 78 %)."""
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    world(scene, (0, 0, 0))
    quad(scene, "Wall", location=(0, 0, -wall), scale=(50, 50, 1))
    cam = scene.camera
    cam.location, cam.rotation_euler = (0, 0, 0), (0, 0, 0)
    cam.data.lens = 18
    cam.data.clip_start, cam.data.clip_end = clip
    c, d = both(scene, tmp_path, normal=False)
    cycles_hit, durer_hit = c["depth"] < MISS, d["depth"] < MISS
    assert cycles_hit.all() if wall > 1 else not cycles_hit.any()
    assert (cycles_hit == durer_hit).all()


def test_tinted_principled_glass_like_cycles(scene, tmp_path):
    """Principled glass tinted by its Base Color b in front of a glowing white wall: Cycles tints what
    each surface passes by √b, so a ball (two surfaces) passes b·(1 − F0)² and a pane (one) √b·(1 − F0);
    a Glass BSDF tints by its Color at each surface (both as Cycles, measured)."""
    from helpers.blender import uv_sphere

    world(scene, (0, 0, 0))
    wall = quad(scene, "Wall", location=(0, 3, 0), scale=(9, 1, 3), rotation=(math.pi / 2, 0, 0))
    wall.data.materials.append(material("Wall", emission=((1.0, 1.0, 1.0), 1.0)))
    tint = (0.3, 0.5, 1.0)
    glass = material("Glass", tint, roughness=0.0)
    bsdf = glass.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Transmission Weight"].default_value, bsdf.inputs["IOR"].default_value = 1.0, 1.45
    bsdf.inputs["Specular IOR Level"].default_value = 0.5
    uv_sphere(scene, "Ball", radius=0.9, location=(-1.5, 0, 0)).data.materials.append(glass)
    quad(scene, "Pane", location=(1.5, 0, 0), scale=(0.8, 1, 0.8), rotation=(math.pi / 2, 0, 0)).data.materials.append(glass)
    cam = aim_camera(scene, (0, -10, 0)).data
    cam.type, cam.ortho_scale = "ORTHO", 6.0
    scene.render.resolution_x, scene.render.resolution_y = 48, 24
    use_cycles(scene, samples=128, max_bounces=8)
    c = render_passes(scene, tmp_path / "cycles.exr", normal=False)
    scene.render.engine, scene.durer.max_bounces = "DURER", 8
    d = render_passes(scene, tmp_path / "durer.exr", normal=False)
    f0 = ((np.float32(1.45) - 1) / (np.float32(1.45) + 1)) ** 2
    ball, pane = (slice(11, 13), slice(11, 13)), (slice(11, 13), slice(35, 37))
    np.testing.assert_allclose(d["color"][ball][..., :3].mean(axis=(0, 1)), np.array(tint) * (1 - f0) ** 2, rtol=2e-3)
    np.testing.assert_allclose(d["color"][pane][..., :3].mean(axis=(0, 1)), np.sqrt(tint) * (1 - f0), rtol=2e-3)
    for at in (ball, pane):
        np.testing.assert_allclose(c["color"][at][..., :3].mean(axis=(0, 1)), d["color"][at][..., :3].mean(axis=(0, 1)),
                                   rtol=0.03)


@pytest.mark.parametrize("projection", ["PERSP", "ORTHO"])
@pytest.mark.parametrize("where", ["clip start through atoms", "camera in an atom"])
def test_a_point_clouds_spheres_seen_from_inside_like_cycles(scene, tmp_path, projection, where):
    """Zoomed into a molecule: where the clip start cuts atoms, or the camera sits in one, Cycles
    culls a point's inside and shows what lies beyond; so does Dürer (a point's sphere is one-sided;
    it drew the inner wall, dark, over 20-60 % of these images). A sphere mesh (a UV sphere around the
    camera's first atom) is drawn from inside by both."""
    from helpers.blender import uv_sphere

    world(scene, (0, 0, 0))
    light(scene, "SUN", energy=2.0, rotation=(math.radians(60), 0, math.radians(25)), angle=0.0)
    rng = np.random.default_rng(2)
    atoms = rng.uniform(-1.5, 1.5, (60, 3))
    pointcloud_object(scene, "Atoms", atoms, radius=0.45).data.materials.append(material("Red", (0.8, 0.1, 0.1)))
    uv_sphere(scene, "Shell", radius=0.3, location=(3.0, 0.0, 2.6)).data.materials.append(material("Shell"))
    cam = aim_camera(scene, (0, -6, 0))
    cam.data.type, cam.data.ortho_scale = projection, 5.0
    if where == "camera in an atom":
        cam.location, cam.data.clip_start = tuple(atoms[0] + (0.0, -0.1, 0.0)), 0.01
    else:
        cam.data.clip_start = 5.0
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    c, d = both(scene, tmp_path, normal=False)
    cycles_hit, durer_hit = c["depth"] < MISS, d["depth"] < MISS
    assert cycles_hit.mean() > 0.3
    assert (cycles_hit != durer_hit).sum() <= 2  # a silhouette's pixel at most
    both_hit = cycles_hit & durer_hit
    np.testing.assert_allclose(d["depth"][both_hit], c["depth"][both_hit], rtol=1e-4, atol=5e-5)
    np.testing.assert_allclose(d["color"][both_hit][:, :3], c["color"][both_hit][:, :3], atol=2e-3)
