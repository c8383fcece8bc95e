"""Effects through Blender: Principled/Glossy/Glass/Refraction/Metallic shaders -> Dürer's Phong,
mirror and refraction parameters; Light Paths settings reaching durer.render; the effect set in
the stats line; mirror, glass and Phong pixels through bpy.ops.render.render."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers.blender import (
    DEG,
    aim_camera,
    export,
    light,
    material,
    quad,
    render_passes,
    use_cycles,
    uv_sphere,
    world,
)

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

import durer
from durer.blender import engine
from durer.blender.export import materials

pytestmark = pytest.mark.blender



def principled(name, base=(0.8, 0.8, 0.8), **inputs):
    """A Principled BSDF material with `inputs` set by socket name (underscores for spaces)."""
    mat = bpy.data.materials.new(name)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*base, 1.0)
    for key, value in inputs.items():
        _set_input(bsdf, key, value)
    return mat


def _set_input(node, key, value):
    sock = node.inputs[key.replace("_", " ")]
    rgb = sock.type == "RGBA" and isinstance(value, tuple) and len(value) == 3
    sock.default_value = (*value, 1.0) if rgb else value


def shader(name, idname, **inputs):
    """A material whose surface is one `idname` shader node with `inputs` set."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    node = tree.nodes.new(idname)
    for key, value in inputs.items():
        if key.islower():
            setattr(node, key, value)
            continue
        _set_input(node, key, value)
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def exported_material(s, mat):
    ball = uv_sphere(s, f"Ball {mat.name}")
    ball.data.materials.append(mat)
    d = export(s)
    bpy.data.objects.remove(ball)
    assert d.sphere_count == 1
    return d.materials[int(d.sphere_materials[0])]


F32 = np.float32


def f32(x):
    return float(F32(x))


# --- material export -------------------------------------------------------------------------------


def test_smooth_metal_is_a_mirror_of_its_base_colour_with_the_lights_glint(scene):
    """A mirror for what rays meet; the lights (points and directions) glint in a highlight as
    narrow as the lobe: roughness 0.05 -> 2/α² − 2 above the largest exponent, 1e4."""
    m = exported_material(scene, principled("Chrome", (0.9, 0.6, 0.3), Metallic=1.0, Roughness=0.05))
    assert m.reflective == pytest.approx((0.9, 0.6, 0.3))
    assert m.exponent == materials.MAX_EXPONENT
    np.testing.assert_allclose(m.specular, np.array([0.9, 0.6, 0.3]) * (1e4 + 8) / 8, rtol=1e-6)
    assert m.diffuse == (0, 0, 0) and m.transparent == (0, 0, 0)
    assert m.effects == {"reflective": m.reflective, "specular": m.specular, "exponent": 1e4}


def test_half_metallic_splits_diffuse_and_mirror(scene):
    base = (0.9, 0.6, 0.3)
    m = exported_material(scene, principled("Half", base, Metallic=0.5, Roughness=0.0, Specular_IOR_Level=0.0))
    np.testing.assert_allclose(m.reflective, np.array(base) * 0.5, rtol=1e-6)
    np.testing.assert_allclose(m.diffuse, np.array(base) * 0.5, rtol=1e-6)
    np.testing.assert_allclose(m.specular, np.array(base) * 0.5 * (1e4 + 8) / 8, rtol=1e-6)


def test_smooth_dielectric_reflects_its_fresnel_f0(scene):
    """IOR 1.5 gives F0 = 0.04; Specular IOR Level 0.5 keeps it, 1 doubles it, tint colours it."""
    m = exported_material(scene, principled("Varnish", (0.2, 0.3, 0.4), Roughness=0.1, IOR=1.5))
    assert m.reflective == pytest.approx((0.04, 0.04, 0.04), rel=1e-6)
    assert m.diffuse == pytest.approx((0.2 * 0.96, 0.3 * 0.96, 0.4 * 0.96))  # below the 4 % layer
    m = exported_material(
        scene,
        principled("Tinted", Roughness=0.1, IOR=1.5, Specular_IOR_Level=1.0, Specular_Tint=(1.0, 0.5, 0.0)),
    )
    assert m.reflective == pytest.approx((0.08, 0.04, 0.0), rel=1e-6)


def test_rough_specular_is_phong_of_the_same_width_and_peak(scene):
    """Blender's default Principled (roughness 0.5, IOR 1.5, level 0.5): α = 0.25, exponent
    2/α² − 2 = 30, ks = F0·(n + 8)/8 = 0.04·38/8 = 0.19; no mirror."""
    m = exported_material(scene, bpy.data.materials.new("Default"))
    assert m.exponent == pytest.approx(30.0)
    assert m.specular == pytest.approx((0.19, 0.19, 0.19), rel=1e-6)
    assert m.diffuse == pytest.approx((0.8 * 0.96,) * 3) and m.reflective == (0, 0, 0)
    assert m.effects == {"specular": m.specular, "exponent": 30.0}
    # A rough metal: the lobe has the base colour; roughness 0.8 -> α = 0.64, n = 2/0.4096 − 2.
    m = exported_material(scene, principled("Brushed", (0.9, 0.6, 0.3), Metallic=1.0, Roughness=0.8))
    n = 2.0 / f32(0.8) ** 4 - 2.0
    assert m.exponent == pytest.approx(n, rel=1e-6)
    np.testing.assert_allclose(m.specular, np.array([0.9, 0.6, 0.3]) * (n + 8) / 8, rtol=1e-6)
    assert m.diffuse == (0, 0, 0)


def test_specular_level_zero_and_roughness_one(scene):
    """No Specular IOR Level: no specular lobe at all (a purely diffuse material asks for no effect);
    roughness 1 gives the smallest exponent, 1."""
    m = exported_material(scene, material("Matte", (0.5, 0.5, 0.5)))  # roughness 1, level 0
    assert m.effects == {}
    m = exported_material(scene, principled("Rough", Roughness=1.0))
    assert m.exponent == 1.0 and m.specular == pytest.approx((0.04 * 9 / 8,) * 3, rel=1e-6)


def test_mirror_roughness_threshold(scene):
    at = exported_material(scene, principled("At", Metallic=1.0, Roughness=materials.MIRROR_ROUGHNESS))
    above = exported_material(scene, principled("Above", Metallic=1.0, Roughness=materials.MIRROR_ROUGHNESS + 0.01))
    assert any(at.reflective) and not any(above.reflective)
    # The highlight is continuous across the threshold: the same formula on both sides.
    assert at.exponent == pytest.approx(2.0 / f32(materials.MIRROR_ROUGHNESS) ** 4 - 2.0, rel=1e-5)
    assert above.exponent == pytest.approx(2.0 / f32(materials.MIRROR_ROUGHNESS + 0.01) ** 4 - 2.0, rel=1e-5)
    assert at.specular[0] == pytest.approx(0.8 * (at.exponent + 8) / 8, rel=1e-6)


def test_transmission_is_refraction_with_the_ior(scene):
    """Transmission t: kd = b·(1 − t)·(1 − F0), transparent = √b·t·(1 − F0) (Cycles tints what each
    surface passes by √b), ior = IOR."""
    base = (0.9, 0.95, 1.0)
    m = exported_material(scene, principled("Glass", base, Transmission_Weight=1.0, IOR=1.45, Roughness=0.0))
    f0 = ((f32(1.45) - 1) / (f32(1.45) + 1)) ** 2
    assert m.ior == pytest.approx(1.45, rel=1e-6)
    np.testing.assert_allclose(m.transparent, np.sqrt(np.float32(base).astype(np.float64)) * (1 - f0), rtol=1e-6)
    assert m.diffuse == (0, 0, 0)
    assert m.reflective == pytest.approx((f0,) * 3, rel=1e-6)
    assert set(m.effects) == {"transparent", "ior", "reflective", "specular", "exponent"}
    m = exported_material(
        scene, principled("Frosted", base, Transmission_Weight=0.5, IOR=1.33, Roughness=0.6, Specular_IOR_Level=0.0)
    )
    assert m.ior == pytest.approx(1.33, rel=1e-6)
    np.testing.assert_allclose(m.transparent, np.sqrt(np.float32(base).astype(np.float64)) * 0.5, rtol=1e-6)
    np.testing.assert_allclose(m.diffuse, np.array(base) * 0.5, rtol=1e-6)
    # A metal is opaque whatever its transmission.
    m = exported_material(scene, principled("Metal", base, Transmission_Weight=1.0, Metallic=1.0))
    assert m.transparent == (0, 0, 0) and m.ior == 1.0


def test_glossy_glass_refraction_and_metallic_shaders(scene):
    glossy = exported_material(
        scene, shader("Glossy", "ShaderNodeBsdfGlossy", Color=(0.7, 0.8, 0.9), Roughness=0.0)
    )
    assert glossy.reflective == pytest.approx((0.7, 0.8, 0.9)) and glossy.diffuse == (0, 0, 0)
    rough = exported_material(scene, shader("RoughGlossy", "ShaderNodeBsdfGlossy", Color=(1, 1, 1), Roughness=0.5))
    assert rough.exponent == 30.0 and rough.specular == pytest.approx((38 / 8,) * 3)
    glass = exported_material(scene, shader("GlassBSDF", "ShaderNodeBsdfGlass", Color=(1.0, 0.5, 0.25), IOR=1.5))
    assert glass.ior == 1.5
    assert glass.transparent == pytest.approx((0.96, 0.48, 0.24))
    assert glass.reflective == pytest.approx((0.04, 0.02, 0.01))
    refr = exported_material(scene, shader("Refr", "ShaderNodeBsdfRefraction", Color=(0.5, 0.5, 0.5), IOR=2.0))
    assert refr.transparent == pytest.approx((0.5, 0.5, 0.5)) and refr.ior == 2.0 and refr.reflective == (0, 0, 0)
    metal = exported_material(
        scene, shader("Gold", "ShaderNodeBsdfMetallic", Base_Color=(1.0, 0.8, 0.3), Roughness=0.1)
    )
    assert metal.reflective == pytest.approx((1.0, 0.8, 0.3))
    conductor = exported_material(
        scene,
        shader(
            "Conductor",
            "ShaderNodeBsdfMetallic",
            fresnel_type="PHYSICAL_CONDUCTOR",
            IOR=(2.0, 1.0, 0.5),
            Extinction=(0.0, 1.0, 3.0),
            Roughness=0.0,
        ),
    )
    assert conductor.reflective == pytest.approx((1 / 9, 1 / 5, (0.25 + 9) / (2.25 + 9)), rel=1e-6)


def test_linked_inputs_use_the_viewport_settings(scene):
    mat = principled("Textured", (0.5, 0.5, 0.5), Metallic=0.0, Roughness=0.9)
    mat.metallic, mat.roughness = 1.0, 0.1  # Viewport Display
    tree = mat.node_tree
    noise = tree.nodes.new("ShaderNodeTexNoise")
    bsdf = tree.nodes["Principled BSDF"]
    tree.links.new(noise.outputs["Fac"], bsdf.inputs["Metallic"])
    tree.links.new(noise.outputs["Fac"], bsdf.inputs["Roughness"])
    m = exported_material(scene, mat)
    assert m.reflective == pytest.approx((0.5, 0.5, 0.5)) and m.diffuse == (0, 0, 0)


def test_materials_differing_only_in_effects_stay_apart(scene):
    uv_sphere(scene, "A").data.materials.append(principled("A", Roughness=0.1, Metallic=1.0))
    uv_sphere(scene, "B", location=(3, 0, 0)).data.materials.append(principled("B", Roughness=0.6, Metallic=1.0))
    uv_sphere(scene, "C", location=(6, 0, 0)).data.materials.append(principled("C", Roughness=0.1, Metallic=1.0))
    d = export(scene)
    ids = {round(c[0]): int(m) for c, m in zip(d.sphere_centers, d.sphere_materials)}
    assert ids[0] == ids[6] != ids[3] and len(d.materials) == 2


def test_phong_exponent_and_lobe_helpers():
    assert materials.phong_exponent(0.5) == 30.0
    assert materials.phong_exponent(1.0) == 1.0 and materials.phong_exponent(0.0) == materials.MAX_EXPONENT
    assert materials.fresnel_f0(1.5) == pytest.approx(0.04) and materials.fresnel_f0(1.0) == 0.0
    assert materials.specular_lobe((0, 0, 0), 0.0) == {}
    # Every mirror's highlight is the mirror's glint to the core: it leaves area lights to the mirror.
    assert materials.phong_exponent(materials.MIRROR_ROUGHNESS) >= durer._core.MIRROR_GLINT_EXPONENT
    assert materials.specular_lobe((0.5, 0.5, 0.5), 0.0) == {
        "reflective": (0.5, 0.5, 0.5), "specular": (0.5 * 10008 / 8,) * 3, "exponent": 1e4}


# --- settings and stats line -----------------------------------------------------------------------


def test_light_paths_settings_defaults_and_kwargs(scene):
    settings = scene.durer
    assert settings.max_bounces == 4 and settings.min_weight == pytest.approx(0.01)
    for name in ("max_bounces", "min_weight"):  # shown in Render Properties > Dürer > Light Paths
        assert settings.bl_rna.properties[name].name in {"Max Bounces", "Min Weight"}
    assert engine.render_kwargs(settings)["min_weight"] == 0.01
    settings.max_bounces, settings.min_weight = 2, 0.25
    kwargs = engine.render_kwargs(settings)
    for key, value in {"max_bounces": 2, "min_weight": 0.25, "shade_back": True}.items():
        assert kwargs[key] == value


def test_float_settings_reach_the_render_as_typed_at_any_magnitude(scene):
    # Blender stores them as float32: read back as the shortest decimal, one way for all (rounding to
    # six places made a min_weight of 1.5e-7 a 0, which turns the weight cut off).
    settings = scene.durer
    settings.min_weight, settings.target_error, settings.time_limit = 1.5e-7, 0.0123456789, 1.1
    kwargs = engine.render_kwargs(settings)
    assert (kwargs["min_weight"], kwargs["target_error"], kwargs["time_limit"]) == (1.5e-7, 0.012345679, 1.1)


def test_stats_line_shows_the_effect_set():
    line = engine.stats_line(64, 48, 2, {"effects": ("diffuse", "reflection", "shadows"), "mrays_per_s": 12.34})
    assert line == "Dürer | 64x48 | 2 spp | diffuse + reflection + shadows | 12.3 Mrays/s"
    assert engine.stats_line(8, 8, 1, {}, cancelled=True) == "Dürer | 8x8 | 1 spp | cancelled"
    # A slow rate (a big scene's export in a tiny image) keeps two digits, not "0.0".
    assert engine.stats_line(8, 8, 1, {"mrays_per_s": 0.0312}) == "Dürer | 8x8 | 1 spp | 0.031 Mrays/s"


# --- renders through bpy.ops.render.render ---------------------------------------------------------

W, H = 63, 47  # odd: the centre pixel's ray is the camera axis


def ortho_camera(s, location, target=(0, 0, 0), scale=4.0):
    cam = aim_camera(s, location, target).data
    cam.type = "ORTHO"
    cam.ortho_scale = scale
    cam.clip_start, cam.clip_end = 0.1, 100.0
    s.render.resolution_x, s.render.resolution_y = W, H
    return cam


EMISSION = (0.2, 0.4, 0.8)
BASE = (0.9, 0.7, 0.5)
WORLD = (0.05, 0.1, 0.15)


def mirror_ball_scene(s):
    """A smooth metal ball at the origin seen along +Y by an orthographic camera; behind the camera
    an emitting quad (the ball's centre reflects it straight back), a Sun and a coloured world."""
    world(s, WORLD)
    uv_sphere(s, "Mirror").data.materials.append(principled("Chrome", BASE, Metallic=1.0, Roughness=0.0))
    panel = quad(s, "Panel", location=(0, -10, 0), rotation=(-90 * DEG, 0, 0), scale=(3, 3, 1))  # faces +Y
    panel.data.materials.append(material("Glow", emission=(EMISSION, 1.0)))
    light(s, "SUN", energy=2.0, rotation=(60 * DEG, 0, 30 * DEG))
    ortho_camera(s, (0, -5, 0))


def hand_built_mirror_scene():
    """The same scene written directly with durer (no export): the reference for the engine."""
    sc = durer.Scene()
    glint = materials.MAX_EXPONENT  # roughness 0: the sun glints in the narrowest highlight
    chrome = sc.add_material(diffuse=(0, 0, 0), reflective=tuple(f32(c) for c in BASE),
                             specular=tuple(f32(c) * (glint + 8) / 8 for c in BASE), exponent=glint)
    glow = sc.add_material(diffuse=(0, 0, 0), emission=tuple(f32(c) for c in EMISSION))
    sc.add_spheres([[0.0, 0.0, 0.0]], [1.0], material=chrome)
    sc.add_plane((0, 1, 0), -10.0, material=glow, bounds=((-3, -10, -3), (0, 0, 6), (6, 0, 0)))
    sun = np.array(bpy.data.objects["Sun"].matrix_world.to_3x3().col[2])
    angle = math.degrees(bpy.data.objects["Sun"].data.angle)  # Blender's 0.526°: it spreads the glint
    sc.add_directional_light(-sun, np.full(3, 2.0 / math.pi), shadows=True, angle_degrees=angle, soft_shadows=False)
    sc.shading = "lit"
    sc.background = (*(f32(c) for c in WORLD), 1.0)
    sc.ambient = tuple(f32(c) for c in WORLD)
    cam = durer.OrthographicCamera((0, -5, 0), (0, 1, 0), (0, 0, 1), size=4.0, t_min=0.1, t_max=100.0)
    return sc, cam


def test_mirror_ball_reflects_the_panel_and_the_world(scene, tmp_path):
    mirror_ball_scene(scene)
    out = render_passes(scene, tmp_path / "mirror.exr", normal=False)
    info = engine.last_render
    assert info.error is None, info.error
    color, hit = out["color"][..., :3], out["depth"] < 1e9
    # Hand computation: the centre ray returns along −Y and sees the panel: base × emission.
    np.testing.assert_allclose(color[H // 2, W // 2], np.multiply(BASE, EMISSION), rtol=1e-5)
    # Near the rim the mirror ray goes past the panel to the world: base × world colour.
    rim = np.argwhere(hit)[np.argmin(np.argwhere(hit)[:, 0])]  # the top-most ball pixel
    np.testing.assert_allclose(color[tuple(rim)], np.multiply(BASE, WORLD), rtol=1e-5)
    # One reflection ray from every pixel that sees the ball, none from the panel's rays.
    stats = info.stats
    assert "reflection" in stats["effects"] and "refraction" not in stats["effects"]
    assert stats["reflection_rays"] == int(hit.sum())
    assert stats["refraction_rays"] == 0
    assert "reflection" in info.stats_line
    # The whole image equals durer's render of the same scene written by hand.
    sc, cam = hand_built_mirror_scene()
    ref = durer.render(sc, cam, W, H, passes=("color",), shade_back=True).color
    # (N·H)^10⁴ turns the sun direction's rounding (float32 in Blender, 1e-8) into 1e-4 of the glint.
    np.testing.assert_allclose(out["color"], ref, rtol=1e-4, atol=1e-6)
    # The sun glints where the ball's normal halves the angle between it and the camera (the
    # passes' rows top first, 4 m across W pixels).
    to_sun = np.array(bpy.data.objects["Sun"].matrix_world.to_3x3().col[2])
    n = to_sun + (0, -1, 0)
    n /= np.linalg.norm(n)
    row, col = np.unravel_index(np.argmax(color.sum(axis=2)), (H, W))
    assert color[row, col].max() > 10 * EMISSION[2]
    assert abs(col + 0.5 - (W / 2 + n[0] * W / 4)) <= 1 and abs(row + 0.5 - (H / 2 - n[2] * W / 4)) <= 1


def test_mirror_ball_centre_like_cycles(scene, tmp_path):
    """Cycles' metal at normal incidence reflects its base colour: the same centre pixel."""
    mirror_ball_scene(scene)
    use_cycles(scene, max_bounces=2)
    scene.cycles.glossy_bounces = 2
    cycles = render_passes(scene, tmp_path / "cycles.exr", depth=False, normal=False)["color"]
    np.testing.assert_allclose(cycles[H // 2, W // 2, :3], np.multiply(BASE, EMISSION), rtol=2e-3)


def test_max_bounces_and_min_weight_reach_the_render(scene):
    mirror_ball_scene(scene)
    scene.durer.max_bounces = 0
    assert bpy.ops.render.render() == {"FINISHED"}
    stats = engine.last_render.stats
    # No bounce at all: the core does not even derive the reflection effect; a black mirror.
    assert "reflection" not in stats["effects"] and stats["reflection_rays"] == 0
    image = bpy.data.images[engine.IMAGE_NAME]
    px = np.empty(W * H * 4, np.float32)
    image.pixels.foreach_get(px)
    assert np.all(px.reshape(H, W, 4)[H // 2, W // 2, :3] == 0)  # no bounce: a black mirror
    scene.durer.max_bounces = 4
    scene.durer.min_weight = 0.95  # above the chrome's largest channel, 0.9
    assert bpy.ops.render.render() == {"FINISHED"}
    stats = engine.last_render.stats
    assert stats["reflection_rays"] == 0 and stats["bounces_cut_by_weight"] > 0
    scene.durer.min_weight = 0.01
    assert bpy.ops.render.render() == {"FINISHED"}
    stats = engine.last_render.stats
    assert stats["reflection_rays"] > 0 and stats["bounces_cut_by_weight"] == 0


def test_glass_ball_lets_the_centre_ray_through(scene, tmp_path):
    """A clear Refraction BSDF ball (IOR 1.5) in front of an emitting panel: the axial ray crosses
    both faces undeviated and sees the panel; with one bounce it is cut inside the ball."""
    world(scene, (0, 0, 0))
    uv_sphere(scene, "Glass").data.materials.append(
        shader("Clear", "ShaderNodeBsdfRefraction", Color=(1.0, 1.0, 1.0), IOR=1.5)
    )
    panel = quad(scene, "Panel", location=(0, 10, 0), rotation=(90 * DEG, 0, 0), scale=(3, 3, 1))
    panel.data.materials.append(material("Glow", emission=(EMISSION, 1.0)))
    light(scene, "SUN", energy=1.0, rotation=(60 * DEG, 0, 30 * DEG))
    ortho_camera(scene, (0, -5, 0), scale=4.0)
    out = render_passes(scene, tmp_path / "glass.exr", depth=False, normal=False)
    np.testing.assert_allclose(out["color"][H // 2, W // 2, :3], EMISSION, rtol=1e-5)
    stats = engine.last_render.stats
    assert "refraction" in stats["effects"] and stats["refraction_rays"] > 0
    assert "refraction" in engine.last_render.stats_line
    assert stats["bounces_cut_by_depth"] == 0
    scene.durer.max_bounces = 1
    out = render_passes(scene, tmp_path / "glass1.exr", depth=False, normal=False)
    np.testing.assert_allclose(out["color"][H // 2, W // 2, :3], 0.0, atol=1e-7)
    # Every ray that entered the ball wanted to leave it at depth 2.
    stats = engine.last_render.stats
    assert stats["bounces_cut_by_depth"] == stats["refraction_rays"] > 0


def test_default_material_gets_a_phong_highlight(scene, tmp_path):
    """Blender's default Principled under a Sun shining along the view: at the centre N = L = H,
    so the pixel is (kd + ks)·S/π = (0.8·0.96 + 0.19)/π."""
    world(scene, (0, 0, 0))
    uv_sphere(scene, "Plastic").data.materials.append(bpy.data.materials.new("Default"))
    ortho_camera(scene, (0, -5, 0))
    sun = light(scene, "SUN", energy=1.0, angle=0.0)  # a point-like sun: the lobe's own highlight
    sun.rotation_euler = scene.camera.rotation_euler
    out = render_passes(scene, tmp_path / "phong.exr", depth=False, normal=False)
    expected = (f32(0.8) * 0.96 + 0.19) / math.pi
    np.testing.assert_allclose(out["color"][H // 2, W // 2, :3], expected, rtol=1e-5)
    effects = engine.last_render.stats["effects"]
    assert "specular" in effects and "reflection" not in effects


def test_cast_shadow_switches_the_shadows_effect(scene):
    world(scene, (0, 0, 0))
    uv_sphere(scene, "Ball").data.materials.append(material("Matte", (0.5, 0.5, 0.5)))
    quad(scene, "Floor", location=(0, 0, -1), scale=(4, 4, 1)).data.materials.append(material("F", (0.5, 0.5, 0.5)))
    sun = light(scene, "SUN", energy=2.0, rotation=(20 * DEG, 0, 0))
    aim_camera(scene, (0, -8, 4))
    scene.render.resolution_x, scene.render.resolution_y = 32, 24
    assert bpy.ops.render.render() == {"FINISHED"}
    stats = engine.last_render.stats
    assert "shadows" in stats["effects"] and stats["shadow_rays"] > 0
    assert "shadows" in engine.last_render.stats_line
    sun.data.use_shadow = False
    assert bpy.ops.render.render() == {"FINISHED"}
    stats = engine.last_render.stats
    assert "shadows" not in stats["effects"] and stats["shadow_rays"] == 0
    assert set(stats["effects"]) == {"diffuse"} and "reflection_rays" in stats


def test_back_faces_are_shaded_like_cycles(scene, tmp_path):
    """Inside a diffuse ball lit by a point light at its centre, the camera sees back faces: Blender
    passes shade_back, so they are lit with the flipped normal (a·P/(4π²r²) at normal incidence)."""
    world(scene, (0, 0, 0))
    room = uv_sphere(scene, "Room", radius=4.0)
    room.data.materials.append(material("Wall", (0.5, 0.5, 0.5)))
    # Smooth: the centre pixel sees a vertex of the UV sphere, where Cycles' normal is then the
    # sphere's, as on the exact sphere Dürer renders (a facet's flat normal there is 1 % off).
    room.data.shade_smooth()
    light(scene, "POINT", energy=100.0, location=(0, 0, 0), shadow_soft_size=0.0)
    cam = aim_camera(scene, (0, 0, 0), (0, 1, 0)).data
    cam.type = "PERSP"
    scene.render.resolution_x, scene.render.resolution_y = W, H
    out = render_passes(scene, tmp_path / "inside.exr", depth=False, normal=False)
    expected = 0.5 * 100.0 / (4 * math.pi**2 * 16.0)
    np.testing.assert_allclose(out["color"][H // 2, W // 2, :3], expected, rtol=1e-4)
    use_cycles(scene)
    cycles = render_passes(scene, tmp_path / "cycles.exr", depth=False, normal=False)["color"]
    np.testing.assert_allclose(cycles[H // 2, W // 2, :3], expected, rtol=1e-4)


def _textured(mat, *names):
    """`mat` with a Noise Texture linked into its surface shader's inputs `names` (a PBR map)."""
    tree = mat.node_tree
    node = tree.nodes["Material Output"].inputs["Surface"].links[0].from_node
    noise = tree.nodes.new("ShaderNodeTexNoise")
    for name in names:
        tree.links.new(noise.outputs["Color" if node.inputs[name].type == "RGBA" else "Fac"], node.inputs[name])
    return mat


def test_inputs_linked_to_textures_take_a_stand_in_and_are_named(scene):
    """A texture in an input Dürer cannot follow: the Viewport Display setting or the socket's own
    value stands in, and the render's notes name the inputs (a metallic map silently drew a
    diffuse ball 3.4 times brighter than Cycles). A texture in an emission colour that does not
    glow changes nothing: not named."""
    metal = _textured(principled("Map", Metallic=1.0, Roughness=0.9, Emission_Strength=0.0),
                      "Metallic", "Roughness", "Emission Color")
    metal.metallic, metal.roughness = 0.25, 0.5
    glass = _textured(shader("Tinted", "ShaderNodeBsdfGlass", Color=(0.1, 0.8, 0.1)), "Color")
    glow = _textured(shader("Sign", "ShaderNodeEmission", Color=(0.2, 0.6, 1.0), Strength=2.0), "Color")
    # Textures the material does not depend on: a tint at Specular IOR Level 0, a metal's IOR and transmission.
    quiet = _textured(principled("Quiet", Metallic=1.0, Specular_IOR_Level=0.0), "Specular Tint", "IOR",
                      "Transmission Weight")
    for x, mat in enumerate((metal, glass, glow, quiet)):
        uv_sphere(scene, mat.name, location=(3 * x, 0, 0)).data.materials.append(mat)
    d = export(scene)
    metal, glass, glow, _ = (d.materials[int(m)] for m in d.sphere_materials[np.argsort(d.sphere_centers[:, 0])])
    np.testing.assert_allclose(metal.diffuse, F32(0.8) * 0.75 * (1 - 0.04), rtol=1e-5)  # metallic 0.25 stands in
    assert metal.exponent == pytest.approx(materials.phong_exponent(F32(0.5)))
    assert glass.transparent == pytest.approx(tuple(F32(0.8) * (1 - 0.04) for _ in range(3)))  # viewport grey
    assert glow.emission == pytest.approx((2.0 * F32(0.2), 2.0 * F32(0.6), 2.0))  # the socket's own colour
    stand_in = ("linked to what it cannot evaluate (a texture, attributes, a node group): the material's Viewport "
                "Display setting or the socket's own value")
    assert sorted(n for n in d.warnings if "one value" in n) == [
        f"Material 'Map': Dürer takes one value for its Metallic, Roughness, {stand_in}",
        f"Material 'Sign': Dürer takes one value for its Color, {stand_in}",
        f"Material 'Tinted': Dürer takes one value for its Color, {stand_in}"]


def test_muted_nodes_pass_what_cycles_passes_and_loops_end(scene):
    """A muted texture passes nothing: the input takes its own value, as in Cycles (it drew the
    viewport colour with a warning); a muted Invert whose input is unlinked passes nothing either
    (the consuming socket's value, not the Invert's input's); a loop of muted nodes (Blender marks
    its closing link invalid, Cycles skips it) ends: it hung the export."""
    muted = principled("Muted texture", base=(0.2, 0.7, 0.3))
    tree = muted.node_tree
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.mute = True
    tree.links.new(texture.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    loop = shader("Loop", "ShaderNodeEmission", Color=(0.3, 0.6, 0.2), Strength=1.5)
    tree = loop.node_tree
    first, second = tree.nodes.new("ShaderNodeInvert"), tree.nodes.new("ShaderNodeInvert")
    first.mute = second.mute = True
    tree.links.new(first.outputs["Color"], second.inputs["Color"])
    tree.links.new(second.outputs["Color"], first.inputs["Color"])  # closes the loop: invalid
    tree.links.new(second.outputs["Color"], tree.nodes["Emission"].inputs["Color"])
    unlinked = shader("Unlinked invert", "ShaderNodeEmission", Color=(0.3, 0.6, 0.2), Strength=1.5)
    tree = unlinked.node_tree
    invert = tree.nodes.new("ShaderNodeInvert")
    invert.inputs["Color"].default_value, invert.mute = (0.2, 0.5, 0.9, 1.0), True
    tree.links.new(invert.outputs["Color"], tree.nodes["Emission"].inputs["Color"])
    for x, mat in enumerate((muted, loop, unlinked)):
        uv_sphere(scene, mat.name, location=(3 * x, 0, 0)).data.materials.append(mat)
    d = export(scene)
    muted, loop, unlinked = (d.materials[int(m)] for m in d.sphere_materials[np.argsort(d.sphere_centers[:, 0])])
    np.testing.assert_allclose(muted.diffuse, F32((0.2, 0.7, 0.3)) * (1 - 0.04), rtol=1e-6)
    assert loop.emission == unlinked.emission == pytest.approx(tuple(1.5 * F32((0.3, 0.6, 0.2))))
    assert not [n for n in d.warnings if "Muted" in n or "one value" in n or "Viewport Display colour" in n]
