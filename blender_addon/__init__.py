"""Match from photo (Kips et al. 2022) for Blender: registration only; the work lives in the modules."""

import os
import sys

_cli_handle = None


def _make_core_importable() -> None:
    """Installed as an extension, vto_core ships inside the add-on (folder _vendor); the console install has it already."""
    vendored = os.path.join(os.path.dirname(__file__), "_vendor")
    if os.path.isdir(vendored) and vendored not in sys.path:
        sys.path.insert(0, vendored)
    # vto_core's dispatcher names commands as blender_addon.<module>, whatever the extension's package is called.
    sys.modules.setdefault("blender_addon", sys.modules[__name__])


def run_cli(argv) -> int:
    """`blender -b [file.blend] -c vto COMMAND ...`: the same dispatcher as the `vto` console script."""
    from vto_core.cli import run

    return run(list(argv))


def register() -> None:
    """Register the `vto` command-line command."""
    import bpy

    global _cli_handle
    _make_core_importable()
    if _cli_handle is None:
        _cli_handle = bpy.utils.register_cli_command("vto", run_cli)


def unregister() -> None:
    """Undo register()."""
    import bpy

    global _cli_handle
    if _cli_handle is not None:
        bpy.utils.unregister_cli_command(_cli_handle)
        _cli_handle = None
