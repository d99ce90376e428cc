"""Match from photo (Kips et al. 2022) for Blender: registration only; the work lives in the modules.

The renderer layer: bpy, vto_core and onnxruntime; it imports no torch, no training and no pipeline, which the
extension does not ship (tests/test_layers.py).
"""

# Installed as an extension, vto_core and onnxruntime come as wheels listed in blender_manifest.toml (Blender installs
# them into its extensions' site-packages); a pip install of the repository has them already. No sys.path edits here.

_cli_handle = None


def run_cli(argv) -> int:
    """`blender -b [file.blend] -c vto COMMAND ...`: the same dispatcher as the `vto` console script.

    The add-on's command modules are looked up in this package: "blender_addon" when pip-installed,
    e.g. "bl_ext.user_default.vto_match" when installed as an extension.
    """
    from vto_core.cli import run

    return run(list(argv), addon_package=__package__)


def register() -> None:
    """Register the `vto` command-line command and the Match-from-photo panels, operators and preferences."""
    import bpy

    global _cli_handle
    if _cli_handle is None:
        _cli_handle = bpy.utils.register_cli_command("vto", run_cli)
    _register_ui()


def _ui_modules():
    """The modules holding the panel, operators, preferences and their properties, in registration order."""
    from .ui import operators, panels, preferences, properties

    return [properties, preferences, operators, panels]


_ui_registered = False


def _register_ui() -> None:
    """Register the Match-from-photo classes (once)."""
    global _ui_registered
    if not _ui_registered:
        for module in _ui_modules():
            module.register()
        _ui_registered = True


def _unregister_ui() -> None:
    global _ui_registered
    if _ui_registered:
        for module in reversed(_ui_modules()):
            module.unregister()
        _ui_registered = False


def unregister() -> None:
    """Undo register()."""
    import bpy

    global _cli_handle
    _unregister_ui()
    if _cli_handle is not None:
        bpy.utils.unregister_cli_command(_cli_handle)
        _cli_handle = None
