"""Blender's camera object and render settings -> `CameraData`."""

from __future__ import annotations

import math

import numpy as np

from .data import CameraData, LensData
from .matrices import world_matrix

#: Cycles' least f-stop and focus distance (intern/cycles/blender/camera.cpp, scene/camera.cpp).
_MIN_FSTOP = 1e-5
_MIN_FOCUS_DISTANCE = 1e-5


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
        lens=lens_data(cam_obj),
    )


def lens_data(cam_obj) -> LensData:
    """The depth of field of camera object `cam_obj` as Cycles syncs it (blender/camera.cpp): the
    aperture from the F-Stop (and the focal length, for perspective), the focus distance along the
    view axis; a pinhole with Depth of Field off."""
    cam = cam_obj.data
    dof = cam.dof
    if not dof.use_dof:
        return LensData()
    fstop = max(float(dof.aperture_fstop), _MIN_FSTOP)
    # Cycles' radius: focal length / (2 F-Stop), taking 1 m for an orthographic camera's focal length.
    focal_length = 1.0 if cam.type == "ORTHO" else cam.lens * 1e-3
    # Cycles samples a disc for fewer than 3 blades; Dürer refuses 1 and 2.
    blades = dof.aperture_blades if dof.aperture_blades >= 3 else 0
    return LensData(
        aperture_radius=focal_length / (2.0 * fstop),
        focus_distance=max(_focus_distance(cam_obj), _MIN_FOCUS_DISTANCE),
        aperture_blades=int(blades),
        aperture_rotation=float(dof.aperture_rotation),
        aperture_ratio=float(dof.aperture_ratio),
    )


def _focus_distance(cam_obj) -> float:
    """Blender's Focus Distance, or with a Focus Object the distance to it (to its bone's head, for
    an armature's Focus Bone) along the view axis, as Cycles measures it."""
    dof = cam_obj.data.dof
    target = dof.focus_object
    if target is None:
        return float(dof.focus_distance)
    m = world_matrix(target.matrix_world)
    bone = target.pose.bones.get(dof.focus_subtarget) if target.pose is not None and dof.focus_subtarget else None
    if bone is not None:
        m = m @ np.array(bone.matrix, dtype=np.float64)
    cam = world_matrix(cam_obj.matrix_world)
    axis = cam[:3, 2] / np.linalg.norm(cam[:3, 2])
    return float(abs(axis @ (cam[:3, 3] - m[:3, 3])))
