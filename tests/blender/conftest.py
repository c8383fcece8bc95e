"""Fixtures for the Blender tests: the real bpy module (Blender 5.0 from PyPI), never a mock."""

from __future__ import annotations

import pytest

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

import durer.blender


@pytest.fixture
def scene():
    """An empty scene (factory settings) with Dürer registered and selected, and a camera."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    durer.blender.register()
    s = bpy.context.scene
    s.render.engine = "DURER"
    s.render.resolution_x, s.render.resolution_y = 64, 48
    s.render.resolution_percentage = 100
    cam = bpy.data.cameras.new("Camera")
    cam_obj = bpy.data.objects.new("Camera", cam)
    s.collection.objects.link(cam_obj)
    s.camera = cam_obj
    yield s
