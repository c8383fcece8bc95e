"""Blender's camera object and render settings -> `CameraData`."""

from __future__ import annotations

import math

import numpy as np

from .data import CameraData
from .matrices import world_matrix


def camera_data(scene, cam_obj) -> CameraData:
    """The camera parameters Dürer needs, from Blender's camera object and render settings."""
    render = scene.render
    width = int(render.resolution_x * render.resolution_percentage // 100)
    height = int(render.resolution_y * render.resolution_percentage // 100)
    if width < 1 or height < 1:
        raise ValueError(f"Render resolution {width}x{height} is empty")
    xasp, yasp = float(render.pixel_aspect_x), float(render.pixel_aspect_y)
    if cam_obj.type != "CAMERA":
        raise ValueError(f"The scene's camera '{cam_obj.name_full}' is an object of type {cam_obj.type}, not a camera: "
                         f"Dürer renders through camera objects")
    cam = cam_obj.data
    if cam.type not in {"ORTHO", "PERSP"}:
        raise ValueError(f"Camera '{cam_obj.name_full}' is panoramic: Dürer renders orthographic and perspective cameras")
    # Blender (BKE_camera_params_compute_viewplane): AUTO fits the larger of xasp·W and yasp·H.
    if cam.sensor_fit == "AUTO":
        fit = "horizontal" if xasp * width >= yasp * height else "vertical"
    else:
        fit = cam.sensor_fit.lower()
    m = world_matrix(cam_obj.matrix_world)
    lin = m[:3, :3]
    direction = -lin[:, 2] / np.linalg.norm(lin[:, 2])
    up = lin[:, 1] / np.linalg.norm(lin[:, 1])
    # Perspective: AUTO and HORIZONTAL use the sensor width, VERTICAL the sensor height.
    sensor = cam.sensor_height if cam.sensor_fit == "VERTICAL" else cam.sensor_width
    fov = math.degrees(2.0 * math.atan(0.5 * sensor / cam.lens))
    return CameraData(
        name=cam_obj.name_full,
        projection="orthographic" if cam.type == "ORTHO" else "perspective",
        center=m[:3, 3].copy(),
        direction=direction,
        up=up,
        size=float(cam.ortho_scale),
        fov_degrees=fov,
        fit=fit,
        sensor_fit=cam.sensor_fit,
        shift=(float(cam.shift_x), float(cam.shift_y)),
        clip_start=float(cam.clip_start),
        clip_end=float(cam.clip_end),
        width=width,
        height=height,
        pixel_aspect=yasp / xasp,
    )
