"""Stage 2 (a real Blender window under Xvfb): the Material tab and the Compositor sidebar, Match pressed with real
X11 clicks (xdotool), undone with a real ctrl+z; screenshots (ImageMagick: Blender's own is black under Xvfb) and
OUT/result.json (written as it goes, so a run that stops still tells how far it got). Every step runs on a timer, so
the window draws and handles the events in between.

Lips: a whole portrait (the add-on finds the lips and reads the photo's light from her skin), Match (Fast) clicked,
undone, clicked twice more, then Better. Eye shadow: the plane "Lid" made active, a whole portrait wearing eye shadow
(the add-on finds both eyes' lids), Match (Fast) clicked, its Preview on Photo, undone, clicked again, then Better and
Best. Hair: a patch of the portrait's hair, Match (Fast), undone; then Better chosen in the sidebar's Quality row (a
real click on its button) and Match clicked: the modal fit runs. A main loop stalled for STALL_S seconds dumps every
thread's Python stack into the log and exits."""
import faulthandler
import importlib
import json
import os
import subprocess
import sys
import time
import traceback

import bpy

RESULT = {"python": sys.version.split()[0], "blender": bpy.app.version_string, "errors": [], "notes": []}
T0 = time.time()
STALL_S = 90  # Blender's main loop stalled this long (no timer tick): dump every thread's Python stack and exit
# From the command line (below); a stage importing these helpers (stage3_character.py) sets OUT, where result.json
# and the screenshots go.
LIPS_REF = HAIR_REF = OUT = EYES_REF = None


def log(*args):
    print(f"STEP [{time.time() - T0:5.1f}s]", *args, flush=True)
    RESULT["last_step"] = " ".join(map(str, args))
    save()


def save():
    with open(os.path.join(OUT, "result.json"), "w") as handle:
        json.dump(RESULT, handle, indent=1)


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


def eyes_inputs():
    (group,) = [n for n in eyes_material().node_tree.nodes if getattr(n, "node_tree", None)
                and n.node_tree.name.startswith("VTO Eye Shadow")]
    return {s.name: round(float(s.default_value), 5) for s in group.inputs if s.type == "VALUE"}


def hair_inputs():
    scene = bpy.context.scene
    return {f"{n.name}.{s.name}": round(float(s.default_value), 5) for n in scene.node_tree.nodes
            if getattr(n, "node_tree", None) and n.node_tree.name.startswith("VTO Hair")
            for s in n.inputs if s.type == "VALUE"}


def find_button(region, shot):
    """The X11 centre of the tallest full-width push button in `region` (Match, drawn 1.4 times as high as the others;
    the lowest of equals), found in the screenshot `shot`: rows of the button grey (84 in the default theme; panel
    headers are 61) across the region, at least 16 pixels high. Blender under Xvfb does not take hover from
    xdotool's motion alone, so the UI cannot be asked which button is where."""
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
    y0, y1 = max(reversed(bands), key=lambda band: band[1] - band[0])
    log("button rows", y0, y1, "of", height, "among", bands)
    return left + width // 2, top + (y0 + y1) // 2


SELECTED = (71, 114, 179)  # the default theme's selected radio button (and ticked checkbox) blue, #4772b3


def find_selected_enum(region, shot):
    """(left, right, top, bottom) in X11 pixels of the selected button of an enum row in `region` (Quality: Fast),
    found in the screenshot `shot`: the widest band of rows, 14 to 32 pixels high, whose selected-blue pixels span
    24 pixels up to half the region with few gaps (a ticked checkbox is 14 pixels wide, the material slot list's
    selected row the whole list; the button's label splits the blue)."""
    import numpy as np

    left, top, width, height = x11_rect(region)
    raw = subprocess.run(["convert", os.path.join(OUT, f"{shot}.png"), "-crop", f"{width}x{height}+{left}+{top}",
                          "+repage", "rgb:-"], check=True, capture_output=True).stdout
    image = np.frombuffer(raw, np.uint8).reshape(height, width, 3).astype(int)
    blue = (np.abs(image - SELECTED) <= 8).all(axis=2)
    spans = []
    for y in range(height):
        xs = np.flatnonzero(blue[y])
        ok = len(xs) >= 16 and 24 <= xs[-1] - xs[0] <= width // 2 and len(xs) >= 0.5 * (xs[-1] - xs[0] + 1)
        spans.append((xs[0], xs[-1]) if ok else None)
    bands, start = [], None
    for y in range(height + 1):
        if y < height and spans[y] is not None and start is None:
            start = y
        elif (y == height or spans[y] is None) and start is not None:
            if bands and start - bands[-1][1] < 6:  # the label's rows split the button's in two
                start = bands.pop()[0]
            bands.append((start, y))
            start = None
    bands = [(a, b) for a, b in bands if 14 <= b - a <= 32]
    if not bands:
        raise RuntimeError(f"no selected enum button found in {shot}")
    y0, y1 = max(bands, key=lambda band: spans[(band[0] + band[1]) // 2][1] - spans[(band[0] + band[1]) // 2][0])
    x0, x1 = spans[(y0 + y1) // 2]
    log("selected button", x0, x1, y0, y1, "of", width, height)
    return left + x0, left + x1, top + y0, top + y1


def modal_operators():
    return [op.bl_idname for op in getattr(window(), "modal_operators", [])]


class MatchFailed(RuntimeError):
    """The click started Match, and it ended without writing (it reported an error)."""


def click_match(props, inputs, name, wait=5.0, running_shot=None):
    """A real click on the hovered Match; waits (up to `wait` s) for the values; returns (values, reported ms).
    `props` gives the settings group (undo replaces it). running_shot: a screenshot of the whole window of that name
    3 s after the click, while it runs. MatchFailed when, 3 s on, nothing was written and no operator runs."""
    before = props().last_estimate  # (a timer may not write ID data while a preview renders: only read here)
    xdo("click", 1)
    clicked = time.time()
    for step in range(int(wait / 0.05)):
        yield 0.05
        if props().last_estimate != before:
            break
        if running_shot and step == 59:
            grab(running_shot)
        if step == 59 and not modal_operators():
            raise MatchFailed(f"{name}: Match ended without writing")
        if step % 100 == 99:  # a long one (Better): what Blender is doing, every 5 s
            cpu = os.times()
            log(name, f"waiting: {len(bpy.data.scenes)} scenes, modal {modal_operators()}, "
                      f"cpu {cpu.user + cpu.system:.0f} s")
    else:
        raise RuntimeError(f"{name}: the click wrote nothing in {wait:g} s")
    ms = 1000 * json.loads(props().last_estimate)["seconds"]
    log(name, f"{ms:.1f} ms (seen {time.time() - clicked:.1f} s after the click)")
    return inputs(), ms


def click_better(record, props, inputs, name, region, quality="BETTER"):
    """A real click on the hovered Match with Better (or `quality`) chosen, in `name`'s panel: its values, reported
    ms and estimate into `record` under that quality's name ('better', 'better_ms', 'better_estimate'; or, where it
    wrote nothing, the error: recorded, not raised), the quality it ran with, and the screenshot NAME_better of `region`
    after it."""
    key = quality.lower()
    try:
        values, ms = yield from click_match(props, inputs, f"{name} {quality.title()} click", wait=120.0,
                                            running_shot=f"{name}_{key}_running")
        record.update({key: values, f"{key}_ms": [ms], f"{key}_estimate": props().last_estimate})
    except MatchFailed as exc:
        record[f"{key}_error"] = str(exc)
        RESULT["errors"].append(record[f"{key}_error"])
        log(record[f"{key}_error"])
    record["quality"] = props().quality
    yield 1.5
    grab(f"{name}_{key}", region)


def button_when_drawn(area, shot, seconds=15.0, settled=False):
    """find_button on a fresh screenshot of `area`, again every half second while the panel has not drawn its buttons
    yet (on two busy cores the panel lays out after Match's preview, or redraws after an undo, a few seconds late). A
    generator: returns (x, y). settled: wait until two screenshots half a second apart show Match in one place (after
    an undo the panel redraws in steps: without the preview, then with the thumbnail that loads on a timer);
    RuntimeError where it has not settled after `seconds`."""
    found, previous, last = None, None, int(seconds * 2)
    for attempt in range(last + 1):
        area.tag_redraw()
        if attempt:
            yield 0.5
        grab(shot, region_of(area))
        try:
            previous, found = found, find_button(region_of(area), shot)
        except RuntimeError:
            if attempt == last:
                raise
            continue
        if not settled or found == previous:
            if attempt:
                log(f"(the buttons were drawn after {attempt / 2:.1f} s more)")
            return found
    raise RuntimeError(f"Match did not settle after the undo: last at {previous}, then {found}")


def retrying(action):
    """Run `action` once Blender allows writing ID data (not while a material preview renders)."""
    refusal = ""
    for attempt in range(600):  # (on two busy cores the first preview icons take a while)
        try:
            done = action()
            if attempt:
                log(f"(Blender allowed writing after {attempt / 10:.1f} s)")
            return done
        except AttributeError as exc:
            if "not allowed" not in str(exc):
                raise
            refusal = str(exc)
        yield 0.1
    raise RuntimeError(f"Blender did not allow writing ID data for 60 s: {refusal}")


def undo():
    """A real ctrl+z, over the window."""
    xdo("key", "ctrl+z")
    yield 1.0


def quality_label(props, renderer="lipstick"):
    """The cost line the panel shows under the Quality row, from the installed extension's panels module."""
    return extension("ui.panels").quality_cost(get_product(renderer), props.quality)


def extension(module):
    """A module of the installed extension (bl_ext.<repo>.vto_match.<module>)."""
    (package,) = [name for name in bpy.context.preferences.addons.keys() if name.endswith(".vto_match")]
    return importlib.import_module(f"{package}.{module}")


def get_product(name):
    """A product's declaration, from the vto_core wheel the extension bundles."""
    return importlib.import_module("vto_core.products").get_product(name)


def lips_found(path):
    """What the add-on's lips locator finds in the reference: its box, how, score, and the frame the encoder reads."""
    reference = extension("matching.reference").read_reference("lipstick", {"image_path": path})
    lips = reference.found
    return {"module": extension("matching.reference").__name__, "box": [int(v) for v in lips.box], "how": lips.how,
            "faces": int(lips.faces), "score": round(float(lips.score), 4), "frame": [int(v) for v in reference.box],
            "size": list(reference.whole.shape[:2])}


def hair_found(path):
    """What the add-on's hair locator finds in the reference: the hair's box and mask (as a share), and the notes."""
    reference = extension("matching.reference").read_reference("hair", {"image_path": path})
    hair = reference.hair
    return {"module": extension("matching.reference").__name__, "box": [int(v) for v in hair.box],
            "faces": int(hair.faces),
            "share": round(float(hair.mask.mean()), 4), "notes": list(reference.notes),
            "mask_rows": [[int(v) for v in row.nonzero()[0][[0, -1]]] if row.any() else [] for row in hair.mask > 0.5]}


def quality_buttons(region, shot):
    """X11 centres of the Fast, Better and Best buttons (three equal buttons, Fast selected in `shot`)."""
    x0, x1, y0, y1 = find_selected_enum(region, shot)
    width = x1 - x0 + 1
    return {"FAST": ((x0 + x1) // 2, (y0 + y1) // 2), "BETTER": (x0 + width * 3 // 2, (y0 + y1) // 2),
            "BEST": (x0 + width * 5 // 2, (y0 + y1) // 2)}


def choose(buttons, quality, props, settle=0.4):
    """Pick `quality` in the Quality row of the settings `props()`, as an artist does: a real click on its button
    (`settle` s after moving there). Falls back to setting the property when the click did not take (noted).
    Returns 'click' or 'property'."""
    xdo("mousemove", *buttons[quality])
    yield settle
    xdo("click", 1)
    for _ in range(40):
        yield 0.05
        if props().quality == quality:
            log(quality, "chosen by a click")
            return "click"
    RESULT["notes"].append(f"the click on {quality} did not choose it")  # (then the property, so the rest runs)
    yield from retrying(lambda: setattr(props(), "quality", quality))
    log(quality, "chosen by the property")
    return "property"


def lips_material():
    return bpy.data.objects["Cube"].active_material  # undo reloads the datablocks: look it up each time


def lips_props():
    return lips_material().vto_match


def eyes_material():
    return bpy.data.objects["Lid"].active_material


def eyes_props():
    return eyes_material().vto_match


def eyes_found(path):
    """Both eyes' lids the add-on finds in the reference: their boxes, and the notes."""
    reference = extension("matching.reference").read_reference("eyeshadow", {"image_path": path})
    return {"boxes": [[int(v) for v in found.box] for _, found in reference.regions], "views": len(reference.images),
            "notes": list(reference.notes)}


def make_active(obj, area):
    """`obj` the active object, and the Properties editor `area` pinned to it (a timer's change of the active object
    sends the editor no notifier: it went on showing the Cube's material)."""
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    space = area.spaces.active
    space.pin_id = obj
    space.use_pin_id = True


def hair_props():
    return bpy.context.scene.vto_hair_match


def taller(area, pixels):
    """Drag the top edge of `area` up by `pixels` (the Outliner above it gets shorter), as an artist does: the
    default window's Properties editor is too short to show the values listed under Match."""
    height = area.height
    x = area.x + area.width // 2
    edge = window().height - (area.y + area.height) - 2  # X11 row of the border above the area
    xdo("mousemove", x, edge)
    yield 0.4
    xdo("mousedown", 1)
    yield 0.2
    for step in range(1, 6):
        xdo("mousemove", x, edge - pixels * step // 5)
        yield 0.1
    xdo("mouseup", 1)
    yield 0.5
    log("properties editor height", height, "->", area.height)
    if area.height == height:
        RESULT["notes"].append("the drag did not move the Properties editor's top edge")
    RESULT["properties_size"] = [area.width, area.height]


def script():
    win = window()
    props_area = area_of("PROPERTIES")
    props_area.spaces.active.context = "MATERIAL"
    yield 1.0
    # what the artist types or browses into Reference (a timer may not write while the material preview renders)
    # ("//astronaut.png": relative to the .blend, which sits beside the photos, as an artist's file browser writes it)
    # Before the drag below: after it, in 3 runs of 8, Blender refused a timer's writes ("drawing/rendering") for
    # over 60 s, then for good.
    yield from retrying(lambda: setattr(lips_props(), "image_path", bpy.path.relpath(LIPS_REF)))
    with bpy.context.temp_override(window=win, area=props_area):
        bpy.ops.ed.undo_push(message="Reference")  # as the UI does after an edit
    yield from taller(props_area, 260)
    props_area.tag_redraw()  # (a timer's edit sends no notifier)
    RESULT["engine"] = bpy.context.scene.render.engine
    yield 4.0  # the panel draws, the encoder loads on its timer, the lips are found for the thumbnail
    grab("lips_before", region_of(props_area))
    defaults = lips_inputs()
    x, y = find_button(region_of(props_area), "lips_before")
    xdo("mousemove", x, y)
    yield 0.5
    first, first_ms = yield from click_match(lips_props, lips_inputs, "lips click 1")
    yield 1.0
    x, y = yield from button_when_drawn(props_area, "lips_after")  # Match, below the preview that moves it down
    shown = extension("ui.preview").shown(lips_material())  # Preview on Photo, made after Match
    RESULT["preview_after_match"] = {"icon": int(shown[0]), "note": shown[1]}
    yield from undo()
    undone = lips_inputs()
    RESULT["reference_after_undo"] = lips_props().image_path
    x, y = yield from button_when_drawn(props_area, "lips_undone", settled=True)
    xdo("mousemove", x, y)
    yield 0.5
    second, second_ms = yield from click_match(lips_props, lips_inputs, "lips click 2")
    yield 0.3
    third, third_ms = yield from click_match(lips_props, lips_inputs, "lips click 3")
    lips = RESULT["lips"] = {"defaults": defaults, "first": first, "undone": undone, "second": second,
                             "third": third, "ms": [first_ms, second_ms, third_ms],
                             "estimate": lips_props().last_estimate, "quality_label": quality_label(lips_props())}
    try:  # the lips the add-on finds, through the installed extension's own module
        lips["found"] = lips_found(LIPS_REF)
    except Exception as exc:  # noqa: BLE001  (recorded, not fatal: the screenshots show the outline)
        RESULT["errors"].append(f"lips box: {type(exc).__name__}: {exc}")

    # The qualities lips are offered (FitPolicy.offered); where Better is one, a real click on it, then Match: the fit
    # in the photo's own scene runs as a modal operator.
    lips["offered"] = list(get_product("lipstick").fit.offered)
    lips["not_offered"] = get_product("lipstick").fit.not_offered
    if "BETTER" in lips["offered"]:
        yield 0.5
        grab("lips_fast_chosen", region_of(props_area))
        lips["better_chosen_by"] = yield from choose(quality_buttons(region_of(props_area), "lips_fast_chosen"),
                                                     "BETTER", lips_props)
        lips["better_label"] = quality_label(lips_props())
        x, y = yield from button_when_drawn(props_area, "lips_better_chosen")
        xdo("mousemove", x, y)
        yield 0.5
        yield from click_better(lips, lips_props, lips_inputs, "lips", region_of(props_area))

    # Eye shadow: the plane "Lid" made active (its VTO Eye Shadow material in the Material tab), a portrait wearing it.
    yield from retrying(lambda: make_active(bpy.data.objects["Lid"], props_area))
    yield from retrying(lambda: setattr(eyes_props(), "image_path", bpy.path.relpath(EYES_REF)))
    with bpy.context.temp_override(window=win, area=props_area):
        bpy.ops.ed.undo_push(message="Eye shadow reference")
    props_area.tag_redraw()
    for _ in range(600):  # Better's modal fit (and the preview it starts) done
        if not modal_operators():
            break
        yield 0.1
    view3d = area_of("VIEW_3D")
    xdo("mousemove", view3d.x + view3d.width // 2, window().height - (view3d.y + view3d.height // 2))
    yield 4.0  # the pointer off the lips' Match: the button it hovered lets go
    x, y = yield from button_when_drawn(props_area, "eyes_before")
    eyes_defaults = eyes_inputs()
    xdo("mousemove", x, y - 3)
    yield 0.3
    xdo("mousemove", x, y)
    yield 0.5
    eyes_first, eyes_ms = yield from click_match(eyes_props, eyes_inputs, "eyes click 1")
    yield 1.0
    x, y = yield from button_when_drawn(props_area, "eyes_after")
    shown = extension("ui.preview").shown(eyes_material())
    eyes = RESULT["eyes"] = {"defaults": eyes_defaults, "first": eyes_first,
                             "preview_after_match": {"icon": int(shown[0]), "note": shown[1]},
                             "estimate": eyes_props().last_estimate, "quality_label": quality_label(eyes_props(),
                                                                                                    "eyeshadow")}
    yield from undo()
    eyes["undone"] = eyes_inputs()
    x, y = yield from button_when_drawn(props_area, "eyes_undone", settled=True)
    xdo("mousemove", x, y)
    yield 0.5
    eyes["second"], second_ms = yield from click_match(eyes_props, eyes_inputs, "eyes click 2")
    yield 0.3
    eyes["third"], third_ms = yield from click_match(eyes_props, eyes_inputs, "eyes click 3")
    eyes["ms"] = [eyes_ms, second_ms, third_ms]
    yield 1.0
    grab("eyes_matched", region_of(props_area))
    # Better and Best, each chosen by a real click in the Quality row, then Match: the fit in the photo's own scene.
    buttons = quality_buttons(region_of(props_area), "eyes_matched")
    for quality in ("BETTER", "BEST"):
        eyes[f"{quality.lower()}_chosen_by"] = yield from choose(buttons, quality, eyes_props)
        eyes[f"{quality.lower()}_label"] = quality_label(eyes_props(), "eyeshadow")
        x, y = yield from button_when_drawn(props_area, f"eyes_{quality.lower()}_chosen")
        xdo("mousemove", x, y)
        yield 0.5
        yield from click_better(eyes, eyes_props, eyes_inputs, "eyes", region_of(props_area), quality)
    try:
        eyes["found"] = eyes_found(EYES_REF)
    except Exception as exc:  # noqa: BLE001  (recorded, not fatal: the screenshots show the outlines)
        RESULT["errors"].append(f"eyes found: {type(exc).__name__}: {exc}")

    # The hair stage: the 3D viewport becomes the Compositor, its sidebar on the VTO tab.
    view = area_of("VIEW_3D")
    view.ui_type = "CompositorNodeTree"
    space = view.spaces.active
    space.show_region_ui = True
    scene = bpy.context.scene
    yield from retrying(lambda: setattr(scene.vto_hair_match, "image_path", bpy.path.relpath(HAIR_REF)))
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
    hx, hy = find_button(sidebar, "hair_before")
    xdo("mousemove", hx, hy)
    yield 0.5
    hair_first, hair_ms = yield from click_match(hair_props, hair_inputs, "hair click 1")
    yield 1.0
    grab("hair_after", sidebar)
    estimate = bpy.context.scene.vto_hair_match.last_estimate
    yield from undo()
    hair_undone = hair_inputs()
    yield 0.5
    hair_second, hair_second_ms = yield from click_match(hair_props, hair_inputs, "hair click 2")
    RESULT["hair"] = {"defaults": hair_defaults, "first": hair_first, "undone": hair_undone, "second": hair_second,
                      "ms": [hair_ms, hair_second_ms], "estimate": estimate,
                      "thumbnail_note": extension("ui.thumbnail")._made.get("HAIR:", (0, 0, ""))[2]}
    try:  # the hair the add-on finds in the whole portrait, through the installed extension's own module
        RESULT["hair"]["found"] = hair_found(HAIR_REF)
    except Exception as exc:  # noqa: BLE001
        RESULT["errors"].append(f"hair found: {type(exc).__name__}: {exc}")

    # Better for hair: a real click on its button in the sidebar's Quality row, then Match; the modal fit runs.
    hair = RESULT["hair"]
    yield 0.5
    grab("hair_fast_chosen", sidebar)
    buttons = quality_buttons(sidebar, "hair_fast_chosen")
    hair["better_chosen_by"] = yield from choose(buttons, "BETTER", hair_props)
    hair["better_label"] = quality_label(hair_props(), "hair")
    xdo("mousemove", hx, hy)
    yield 0.5
    yield from click_better(hair, hair_props, hair_inputs, "hair", sidebar)
    RESULT["completed"] = True


def run(steps, stage, shown=("lips", "eyes", "hair", "errors", "notes"), stall_s=None):
    """Run the generator `steps` on Blender's timer (each value it yields: seconds to the next step), then save
    result.json, print its `shown` parts as one line "RESULT <stage> ..." and exit. A main loop stalled for `stall_s`
    (default STALL_S) seconds dumps every thread's Python stack into the log and exits."""

    def tick():
        # re-armed at each tick: a deadlock fails fast, with stacks
        faulthandler.dump_traceback_later(stall_s or STALL_S, exit=True)
        try:
            return next(steps)
        except StopIteration:
            pass
        except Exception:
            RESULT["errors"].append(traceback.format_exc())
            traceback.print_exc()
        save()
        print(f"RESULT {stage} " + json.dumps({k: v for k, v in RESULT.items() if k in shown})[:4000])
        sys.stdout.flush()
        os._exit(0)  # quit_blender from a timer may refuse ("drawing/rendering"); nothing is left to save

    bpy.app.timers.register(tick, first_interval=3.0)


if __name__ == "__main__":  # (Blender runs a --python script as __main__)
    LIPS_REF, HAIR_REF, OUT, EYES_REF = sys.argv[sys.argv.index("--") + 1:][:4]
    run(script(), "stage2")
