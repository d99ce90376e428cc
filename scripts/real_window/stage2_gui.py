"""Stage 2 (a real Blender window under Xvfb): the Material tab and the Compositor sidebar, Match pressed with real
X11 clicks (xdotool), undone with a real ctrl+z; screenshots (ImageMagick: Blender's own is black under Xvfb) and
OUT/result.json. Every step runs on a timer, so the window draws and handles the events in between."""
import json
import os
import subprocess
import sys
import time
import traceback

import bpy

LIPS_REF, HAIR_REF, OUT = sys.argv[sys.argv.index("--") + 1:][:3]
RESULT = {"python": sys.version.split()[0], "blender": bpy.app.version_string, "errors": []}
T0 = time.time()


def log(*args):
    print(f"STEP [{time.time() - T0:5.1f}s]", *args, flush=True)


def window():
    return bpy.context.window_manager.windows[0]


def area_of(kind):
    return next(a for a in window().screen.areas if a.type == kind)


def region_of(area, kind="WINDOW"):
    return next(r for r in area.regions if r.type == kind)


def xdo(*args):
    subprocess.run(["xdotool", *map(str, args)], check=True)


def x11_rect(region):
    """(left, top, width, height) of a region in X11 screen pixels (the window sits at 0, 0)."""
    return region.x, window().height - (region.y + region.height), region.width, region.height


def grab(name, region=None):
    """The whole screen as OUT/name.png, and the region alone as OUT/name_panel.png."""
    path = os.path.join(OUT, f"{name}.png")
    subprocess.run(["import", "-window", "root", path], check=True)
    if region is not None:
        left, top, width, height = x11_rect(region)
        subprocess.run(["convert", path, "-crop", f"{width}x{height}+{left}+{top}", "+repage",
                        os.path.join(OUT, f"{name}_panel.png")], check=True)
    log("screenshot", name)


def lips_inputs():
    material = bpy.data.objects["Cube"].active_material
    (group,) = [n for n in material.node_tree.nodes if getattr(n, "node_tree", None)
                and n.node_tree.name.startswith("VTO Lipstick")]
    return {s.name: round(float(s.default_value), 5) for s in group.inputs if s.type == "VALUE"}


def hair_inputs():
    scene = bpy.context.scene
    return {f"{n.name}.{s.name}": round(float(s.default_value), 5) for n in scene.node_tree.nodes
            if getattr(n, "node_tree", None) and n.node_tree.name.startswith("VTO Hair")
            for s in n.inputs if s.type == "VALUE"}


def find_button(region, shot):
    """The X11 centre of the full-width push button lowest in `region` (Match: the only button spanning the panel),
    found in the screenshot `shot`: rows of the button grey (84 in the default theme; panel headers are 61) across the region, at least 16 pixels high. Blender under
    Xvfb does not take hover from xdotool's motion alone, so the UI cannot be asked which button is where."""
    import numpy as np

    left, top, width, height = x11_rect(region)
    raw = subprocess.run(["convert", os.path.join(OUT, f"{shot}.png"), "-crop", f"{width}x{height}+{left}+{top}",
                          "+repage", "rgb:-"], check=True, capture_output=True).stdout
    image = np.frombuffer(raw, np.uint8).reshape(height, width, 3).astype(int)[:, 14:width - 14]
    grey = image.max(axis=2) - image.min(axis=2) < 6
    bands, start = [], None
    for y in range(height + 1):
        ok = False
        if y < height:
            row = image[y, :, 0]
            mode = np.bincount(row).argmax()
            ok = 75 <= mode <= 120 and ((np.abs(row - mode) <= 4) & grey[y]).mean() > 0.6
        if ok and start is None:
            start = y
        elif not ok and start is not None:
            if bands and start - bands[-1][1] < 12:  # the label splits the button's rows in two
                start = bands.pop()[0]
            bands.append((start, y))
            start = None
    bands = [(a, b) for a, b in bands if b - a >= 16]
    if not bands:
        raise RuntimeError(f"no push button found in {shot}")
    y0, y1 = bands[-1]
    log("button rows", y0, y1, "of", height)
    return left + width // 2, top + (y0 + y1) // 2


def click_match(props, inputs, name):
    """A real click on the hovered Match; waits for the values; returns (values, reported ms)."""
    before = props.last_estimate  # (a timer may not write ID data while a preview renders: only read here)
    xdo("click", 1)
    for _ in range(100):
        yield 0.05
        if props.last_estimate != before:
            break
    else:
        raise RuntimeError(f"{name}: the click wrote nothing")
    ms = 1000 * json.loads(props.last_estimate)["seconds"]
    log(name, f"{ms:.1f} ms")
    return inputs(), ms


def retrying(action):
    """Run `action` once Blender allows writing ID data (not while a material preview renders)."""
    for _ in range(100):
        try:
            return action()
        except AttributeError as exc:
            if "not allowed" not in str(exc):
                raise
        yield 0.1
    raise RuntimeError("Blender did not allow writing ID data for 10 s")


def undo():
    """A real ctrl+z, over the window."""
    xdo("key", "ctrl+z")
    yield 1.0


def script():
    win = window()
    props_area = area_of("PROPERTIES")
    props_area.spaces.active.context = "MATERIAL"
    material = bpy.data.objects["Cube"].active_material
    material.vto_match.image_path = LIPS_REF  # what the artist types or browses into Reference
    with bpy.context.temp_override(window=win, area=props_area):
        bpy.ops.ed.undo_push(message="Reference")  # as the UI does after an edit
    RESULT["engine"] = bpy.context.scene.render.engine
    yield 4.0  # the panel draws, the encoder loads on its timer
    grab("lips_before", region_of(props_area))
    defaults = lips_inputs()
    x, y = find_button(region_of(props_area), "lips_before")
    xdo("mousemove", x, y)
    yield 0.5
    first, first_ms = yield from click_match(material.vto_match, lips_inputs, "lips click 1")
    yield 1.0
    grab("lips_after", region_of(props_area))
    yield from undo()
    undone = lips_inputs()
    material = bpy.data.objects["Cube"].active_material  # undo reloads the datablocks: old references are gone
    RESULT["reference_after_undo"] = material.vto_match.image_path
    xdo("mousemove", x, y)
    yield 0.5
    second, second_ms = yield from click_match(material.vto_match, lips_inputs, "lips click 2")
    yield 0.3
    third, third_ms = yield from click_match(material.vto_match, lips_inputs, "lips click 3")
    RESULT["lips"] = {"defaults": defaults, "first": first, "undone": undone, "second": second, "third": third,
                      "ms": [first_ms, second_ms, third_ms], "estimate": material.vto_match.last_estimate}

    # The hair stage: the 3D viewport becomes the Compositor, its sidebar on the VTO tab.
    view = area_of("VIEW_3D")
    view.ui_type = "CompositorNodeTree"
    space = view.spaces.active
    space.show_region_ui = True
    scene = bpy.context.scene
    yield from retrying(lambda: setattr(scene.vto_hair_match, "image_path", HAIR_REF))
    with bpy.context.temp_override(window=win, area=view):
        bpy.ops.ed.undo_push(message="Hair reference")
    yield 1.0
    sidebar = region_of(view, "UI")
    try:
        sidebar.active_panel_category = "VTO"
    except (AttributeError, TypeError) as exc:
        RESULT["errors"].append(f"sidebar tab: {exc}")
    for window_area in win.screen.areas:
        window_area.tag_redraw()
    yield 3.0
    grab("hair_before", sidebar)
    hair_defaults = hair_inputs()
    x, y = find_button(sidebar, "hair_before")
    xdo("mousemove", x, y)
    yield 0.5
    hair_first, hair_ms = yield from click_match(scene.vto_hair_match, hair_inputs, "hair click 1")
    yield 1.0
    grab("hair_after", sidebar)
    estimate = scene.vto_hair_match.last_estimate
    yield from undo()
    RESULT["hair"] = {"defaults": hair_defaults, "first": hair_first, "undone": hair_inputs(), "ms": [hair_ms],
                      "estimate": estimate}


STEPS = script()


def tick():
    try:
        return next(STEPS)
    except StopIteration:
        pass
    except Exception:
        RESULT["errors"].append(traceback.format_exc())
        traceback.print_exc()
    with open(os.path.join(OUT, "result.json"), "w") as handle:
        json.dump(RESULT, handle, indent=1)
    print("RESULT stage2 " + json.dumps({k: v for k, v in RESULT.items() if k in ("lips", "hair", "errors")})[:3000])
    sys.stdout.flush()
    os._exit(0)  # quit_blender from a timer may refuse ("drawing/rendering"); nothing is left to save


bpy.app.timers.register(tick, first_interval=3.0)
