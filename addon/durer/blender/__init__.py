"""Dürer inside Blender: the render engine, its settings and panels, batch rendering and the
extension package.

In a ``bpy`` script::

    import bpy
    import durer.blender
    durer.blender.register()
    bpy.context.scene.render.engine = "DURER"
    bpy.ops.render.render(write_still=True)

Installed as a Blender extension, Blender calls `register` / `unregister` itself. The modules
that define Blender classes (engine, properties, ui, import_6837) import bpy; importing this
package alone does not, so `durer.blender.extension` (which builds the extension zip) works
without Blender.
"""

from __future__ import annotations

_registered = False


def register() -> None:
    """Register the Dürer engine ("DURER"), its settings (scene.durer, object.durer, material.durer,
    light.durer), its panels and File > Import > 6.837 scene (.txt). Calling it again while
    registered does nothing."""
    global _registered
    if _registered:
        return
    from . import engine, import_6837, properties, ui

    properties.register()
    engine.register()
    ui.register()
    import_6837.register()
    _registered = True


def unregister() -> None:
    """Undo `register` (does nothing if not registered)."""
    global _registered
    if not _registered:
        return
    from . import engine, import_6837, properties, ui

    import_6837.unregister()
    ui.unregister()
    engine.unregister()
    properties.unregister()
    _registered = False


def is_registered() -> bool:
    return _registered
