"""Bounces at the validated maximum (1,000) between two facing mirrors: no stack overflow on the
render threads, in both precisions and through the 6.837 command line; and a ray tree that would
double at every level refused before it is traced."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from PIL import Image

import durer
from durer.render import PRECISIONS

MAX_BOUNCES = 1000  # the core's limit (Renderer.cpp's validate)


def facing_mirrors() -> tuple[durer.Scene, durer.PerspectiveCamera]:
    """Mirrors at z = -1 and z = +1 facing each other, a camera between them looking at one: every
    camera ray bounces back and forth until max_bounces cuts it."""
    scene = durer.Scene()
    mirror = scene.add_material((0.25, 0.125, 0.0625), reflective=(0.5, 0.5, 0.5))
    scene.add_plane((0, 0, 1), -1.0, material=mirror)
    scene.add_plane((0, 0, -1), -1.0, material=mirror)
    return scene, durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=10)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_the_maximum_bounce_depth_renders(precision):
    scene, camera = facing_mirrors()
    with pytest.raises(ValueError, match=r"max_bounces must be in \[0, 1000\]"):
        durer.render(scene, camera, 8, 8, max_bounces=MAX_BOUNCES + 1, min_weight=0)
    result = durer.render(scene, camera, 8, 8, max_bounces=MAX_BOUNCES, min_weight=0, precision=precision, threads=2)
    assert result.stats["reflection_rays"] == 64 * MAX_BOUNCES
    assert result.stats["bounces_cut_by_depth"] == 64
    # flat shading: c = kd + 0.5·c' down the chain, so kd·(2 - 2^-1000) = 2·kd to the last bit of double
    expected = np.array([0.5, 0.25, 0.125, 1.0], dtype=np.float32)
    assert np.allclose(result.color, expected, rtol=1e-6, atol=0)


def test_the_maximum_bounce_depth_through_the_6837_command_line(tmp_path):
    scene = tmp_path / "mirrors.txt"
    scene.write_text(textwrap.dedent("""\
        PerspectiveCamera { center 0 0 0 direction 0 0 -1 up 0 1 0 angle 10 }
        Background { color 0 0 0 ambientLight 0 0 0 }
        Materials { numMaterials 1
            PhongMaterial { diffuseColor 0.25 0.125 0.0625 reflectiveColor 0.5 0.5 0.5 } }
        Group { numObjects 2 MaterialIndex 0
            Plane { normal 0 0 1 offset -1 }
            Plane { normal 0 0 -1 offset -1 } }
        """))
    out = tmp_path / "mirrors.png"
    done = subprocess.run([sys.executable, "-m", "durer", "raytracer", "-input", str(scene), "-size", "8", "8",
                           "-output", str(out), "-bounces", str(MAX_BOUNCES), "-weight", "0"],
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    # 6.837 bytes: linear colour truncated, 2·kd = (0.5, 0.25, 0.125) -> (127, 63, 31)
    assert np.array_equal(np.asarray(Image.open(out).convert("RGB")), np.full((8, 8, 3), (127, 63, 31), np.uint8))



def doubling_mirrors(reflective: float, transparent: float) -> durer.Scene:
    """The facing mirrors, each also refracting: every hit spawns a reflected and a refracted ray."""
    scene = durer.Scene()
    glass = scene.add_material((0.25, 0.125, 0.0625), reflective=(reflective,) * 3, transparent=(transparent,) * 3)
    scene.add_plane((0, 0, 1), -1.0, material=glass)
    scene.add_plane((0, 0, -1), -1.0, material=glass)
    return scene


# Level k of a camera ray's tree holds at most 2^k rays, and at most c^k / min_weight of weight
# min_weight or more (c: a material's largest reflective + transparent): more than 2^17 rays in all
# is refused before tracing (a fuzzed 8x8 render with max_bounces=30 ran for hours).
@pytest.mark.parametrize(("reflective", "transparent", "min_weight", "deepest"), [
    (0.5, 0.5, 0.0, 16),     # c = 1, nothing pruned: 2^17 - 1 rays at 16 bounces, 2^18 - 1 at 17
    (1.05, 1.73, 0.01, 16),  # the fuzz's material, whose weights only grow
    (0.1, 0.9, 0.01, MAX_BOUNCES),  # glass: at most 100 rays a level, at the deepest max_bounces allowed
])
def test_a_ray_tree_that_would_not_end_is_refused(reflective, transparent, min_weight, deepest):
    scene, (_, camera) = doubling_mirrors(reflective, transparent), facing_mirrors()
    result = durer.render(scene, camera, 2, 2, max_bounces=deepest, min_weight=min_weight)
    assert result.stats["reflection_rays"] > 0 and result.stats["refraction_rays"] > 0
    if deepest < MAX_BOUNCES:
        refused = rf"max_bounces={deepest + 1} with min_weight={min_weight:g} lets one camera ray spawn more than 131072 "
        with pytest.raises(ValueError, match=refused + r".*lower max_bounces or raise min_weight"):
            durer.render(scene, camera, 2, 2, max_bounces=deepest + 1, min_weight=min_weight)
    # A depth render traces no bounce: nothing to refuse. Its one sample per pixel is the pixel's centre,
    # (±tan 5°/2, ±tan 5°/2) on the mirror z = -1 a unit ahead: t = sqrt(1 + tan² 5° / 2) everywhere.
    depth = durer.render(scene, camera, 2, 2, passes="depth", max_bounces=MAX_BOUNCES, min_weight=0)
    assert depth.stats["reflection_rays"] == depth.stats["refraction_rays"] == 0
    np.testing.assert_allclose(depth.depth, np.full((2, 2), np.sqrt(1 + np.tan(np.radians(5)) ** 2 / 2)), rtol=1e-6)
