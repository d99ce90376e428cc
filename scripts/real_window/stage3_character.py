"""Stage 3 (a real Blender window under Xvfb): the artist's own character. The MakeHuman head (a copy of
data/heads/makehuman.blend: one mesh under one skin material, and the eyes) opened; the 3D Viewport in front view framed
on the head, its sidebar on the VTO tab. With real X11 clicks (xdotool): Find Face on Mesh (its regions in the solid
shading, the front render's thumbnail in the panel), Add Lipstick Layer, Add Eye Shadow Layer; the reference (the
portrait wearing Royal Purple eye shadow) set in the skin material's Match from photo panel, Match (Fast) for the eye
shadow layer (chosen first, as the newest), Lipstick in the Fill row, Match again; then the viewport in Material
Preview through the face camera. Screenshots OUT/character_*.png; result.json's "character", beside stage 2's entries
(the file stage 2 left is read first). Stage 2's helpers (screenshots, clicks, buttons found in them, the timer loop)
are imported from stage2_gui.py beside this file."""
import json
import os
import subprocess
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import stage2_gui as gui  # noqa: E402
from stage2_gui import (RESULT, area_of, click_match, extension,  # noqa: E402
                        grab, log, region_of, retrying, window, x11_rect, xdo)

EYES_REF, OUT = sys.argv[sys.argv.index("--") + 1:][:2]
gui.OUT = OUT
if os.path.exists(os.path.join(OUT, "result.json")):  # stage 2's: this stage's entries join them
    with open(os.path.join(OUT, "result.json")) as handle:
        RESULT.update({k: v for k, v in json.load(handle).items() if k not in ("python", "blender")})
RESULT.setdefault("errors", [])
RESULT.setdefault("notes", [])
CHARACTER = RESULT["character"] = {"file": bpy.data.filepath}
FIND_WAIT_S = 240.0  # Find Face on Mesh renders the mesh in Cycles (a few views, 4 samples) on two busy cores
BUTTON_GREY = (75, 120)  # the default theme's push button (84; hovered a little lighter); panel backs are 48 to 61


def head():
    """The character's head: the mesh with the most vertices (looked up each time: undo reloads the datablocks)."""
    return max((o for o in bpy.data.objects if o.type == "MESH"), key=lambda o: len(o.data.vertices))


def skin():
    return head().active_material


def worn():
    """{product name: its layer's group node} of the skin material (the installed extension's makeup_layer)."""
    return {product.name: node for product, node in extension("renderers.makeup_layer").layers(skin())}


def layer_inputs(name):
    """The VALUE inputs of the `name` layer's group node (lipstick, eyeshadow)."""
    return {s.name: round(float(s.default_value), 5) for s in worn()[name].inputs if s.type == "VALUE"}


def skin_props():
    return skin().vto_match


def crop(shot, name, left, top, width, height):
    """OUT/name.png: the (left, top, width, height) part of the screenshot OUT/shot.png (X11 pixels)."""
    subprocess.run(["convert", os.path.join(OUT, f"{shot}.png"), "-crop", f"{width}x{height}+{left}+{top}",
                    "+repage", os.path.join(OUT, f"{name}.png")], check=True)


def pixels(shot, rect):
    """The (left, top, width, height) part of the screenshot OUT/shot.png: (height, width, 3) int."""
    left, top, width, height = rect
    raw = subprocess.run(["convert", os.path.join(OUT, f"{shot}.png"), "-crop", f"{width}x{height}+{left}+{top}",
                          "+repage", "rgb:-"], check=True, capture_output=True).stdout
    return np.frombuffer(raw, np.uint8).reshape(height, width, 3).astype(int)


def push_buttons(region, shot, inset=(42, 72)):
    """The X11 rows (top, bottom) of the full-width push buttons in `region`, top to bottom, found in the screenshot
    `shot`: rows whose strip `inset` pixels in from the region's left edge (right of a button's icon, left of its
    centred label) is the button grey, at least 14 rows high. The sidebar stacks its buttons a few pixels
    apart, which stage 2's find_button (a label splits a button's rows) would take for one."""
    left, top, width, height = x11_rect(region)
    image = pixels(shot, (left, top, width, height))[:, inset[0]:inset[1]]
    grey = image.max(axis=2) - image.min(axis=2) < 6
    ok = (grey & (image[..., 0] >= BUTTON_GREY[0]) & (image[..., 0] <= BUTTON_GREY[1])).mean(axis=1) > 0.9
    bands, start = [], None
    for y in range(height + 1):
        if y < height and ok[y] and start is None:
            start = y
        elif (y == height or not ok[y]) and start is not None:
            if y - start >= 14:
                bands.append((top + start, top + y))
            start = None
    log("push buttons in", shot, bands)
    return bands


def hover(x, y, settle=0.5):
    """The pointer moved to (x, y) (from 3 pixels above: a move onto the button), and `settle` s given to it."""
    xdo("mousemove", x, y - 3)
    yield 0.2
    xdo("mousemove", x, y)
    yield settle


def click_at(x, y, settle=0.5):
    """A real click at (x, y), the pointer moved there first."""
    yield from hover(x, y, settle)
    xdo("click", 1)


def last_tab(sidebar, shot):
    """The X11 centre of the last tab (VTO: the add-on's, after Blender's Item, Tool and View) in the tab strip at the
    right edge of `sidebar`, in the screenshot `shot`: runs of 15 or more rows, 5 pixels in from the strip's left,
    lighter than the strip (24 in the default theme; a tab 29, the chosen one 48)."""
    left, top, width, height = x11_rect(sidebar)
    column = pixels(shot, (left + width - 24 + 5, top, 1, height))[:, 0, 0]
    tabs, start = [], None
    for y in range(height + 1):
        if y < height and column[y] > 26 and start is None:
            start = y
        elif (y == height or column[y] <= 26) and start is not None:
            if y - start >= 15:
                tabs.append((start, y))
            start = None
    log("sidebar tabs", tabs)
    if not tabs:
        raise RuntimeError(f"no tabs found in the sidebar ({shot})")
    return left + width - 12, top + sum(tabs[-1]) // 2


def panel_button(area, region_kind, shot, pick, seconds=15.0):
    """The X11 centre of the push button `pick(bands)` chooses (bands: push_buttons' rows, top to bottom; None: not
    drawn yet) in `area`'s region `region_kind`, from a fresh screenshot `shot`, again every half second for `seconds`
    while it chooses none (on two busy cores a panel lays out a few seconds late)."""
    region = region_of(area, region_kind)
    for attempt in range(int(2 * seconds) + 1):
        area.tag_redraw()
        yield 0.5
        grab(shot, region)
        bands = push_buttons(region, shot)
        chosen = pick(bands)
        if chosen is not None:
            top, bottom = chosen
            return x11_rect(region)[0] + 56, (top + bottom) // 2  # (left of the label: a click anywhere takes)
    raise RuntimeError(f"the button was not drawn in {shot}: {bands}")


def nth(index, count):
    """pick for panel_button: button `index` of `count` or more."""
    return lambda bands: bands[index] if len(bands) >= count else None


def tallest(bands):
    """pick for panel_button: Match (1.4 times as high as the other buttons: 26 rows or more)."""
    band = max(bands, key=lambda b: b[1] - b[0], default=None)
    return band if band is not None and band[1] - band[0] >= 26 else None


def selected_buttons(region, shot):
    """(left, right, top, bottom) X11 pixels of each band of selected-blue (SELECTED) buttons in `region`, top to
    bottom: rows of 16 or more blue pixels spanning 24 pixels up to half the region (the Fill row's layer, the
    Quality row's Fast; not the material slot list's selected row, nor a ticked checkbox), 14 to 32 rows high."""
    left, top, width, height = x11_rect(region)
    blue = (np.abs(pixels(shot, (left, top, width, height)) - gui.SELECTED) <= 8).all(axis=2)
    spans = []
    for y in range(height):
        xs = np.flatnonzero(blue[y])
        ok = len(xs) >= 16 and 24 <= xs[-1] - xs[0] <= width // 2  # (the label thins the blue of its rows)
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
    found = [(left + int(spans[(a + b) // 2][0]), left + int(spans[(a + b) // 2][1]), top + a, top + b)
             for a, b in bands if 14 <= b - a <= 32]
    log("selected buttons in", shot, found)
    return found


def area_rect(area):
    """(left, top, width, height) of an area in X11 screen pixels (its header included)."""
    return area.x, window().height - (area.y + area.height), area.width, area.height


def views_docs(name, view):
    """OUT/name_docs.png (from OUT/name.png): the viewport's right part, up to 960 pixels of it: the head and the
    sidebar."""
    left, top, width, height = area_rect(view)
    start = max(left, left + width - 960)
    crop(name, f"{name}_docs", start, top, left + width - start, height)


def purple_pixels(shot, view):
    """How many pixels of the viewport (in the screenshot `shot`) are purple (blue over red over green): the eye
    shadow on the lids, once EEVEE has compiled the skin's shaders."""
    image = pixels(shot, x11_rect(region_of(view)))
    red, green, blue = image[..., 0], image[..., 1], image[..., 2]
    return int(((blue > green + 20) & (blue > red) & (red > green)).sum())  # (the gizmo's blue: red under green)


def settled(view, shot, seconds, region=None):
    """Screenshots `shot` (and `region`'s crop) every 3 s until the eye shadow shows (purple_pixels) and two shots
    agree, or `seconds` pass (then False): the viewport renders (EEVEE compiling its shaders, Cycles sampling) while
    the window runs."""
    previous, started = None, time.time()
    while time.time() - started < seconds:
        view.tag_redraw()
        yield 3.0
        grab(shot, region)
        now = pixels(shot, x11_rect(region_of(view)))
        purple = purple_pixels(shot, view)
        log(f"viewport: {purple} purple pixels, {np.abs(now - previous).mean() if previous is not None else -1:.2f} "
            "mean change")
        if previous is not None and purple >= 100 and np.abs(now - previous).mean() < 0.5:
            log(f"the viewport settled after {time.time() - started:.0f} s: {purple} purple pixels")
            return True
        previous = now
    log(f"the viewport did not settle in {seconds:g} s ({purple_pixels(shot, view)} purple pixels)")
    return False


def drag(start, end, steps=5):
    """A real drag with the left button from X11 (x, y) `start` to `end` (an area's edge, as an artist drags it)."""
    xdo("mousemove", *start)
    yield 0.4
    xdo("mousedown", 1)
    yield 0.2
    for step in range(1, steps + 1):
        xdo("mousemove", *(round(a + (b - a) * step / steps) for a, b in zip(start, end)))
        yield 0.1
    xdo("mouseup", 1)
    yield 0.5


def script():
    win = window()
    view = area_of("VIEW_3D")
    space = view.spaces.active
    obj = head()
    # The Properties editor wider and taller (the Outliner above it shorter), as an artist drags the edges: the
    # default one is too narrow for the Fill row and too short for Match below the skin material's previews.
    props_area = area_of("PROPERTIES")
    size = [props_area.width, props_area.height]
    edge = window().height - (props_area.y + props_area.height) - 2  # X11 row of the border above it
    yield from drag((props_area.x + props_area.width // 2, edge), (props_area.x + props_area.width // 2, edge - 250))
    middle = window().height - (props_area.y + props_area.height // 2)
    yield from drag((props_area.x - 2, middle), (props_area.x - 122, middle))
    view, props_area = area_of("VIEW_3D"), area_of("PROPERTIES")
    CHARACTER["properties_size"] = [size, [props_area.width, props_area.height]]
    log("properties editor", *CHARACTER["properties_size"])
    if CHARACTER["properties_size"][1][0] <= size[0] or CHARACTER["properties_size"][1][1] <= size[1]:
        RESULT["notes"].append(f"the drags did not move the Properties editor's edges: {CHARACTER['properties_size']}")
    CHARACTER.update({"object": obj.name, "vertices": len(obj.data.vertices), "material": skin().name,
                      "window": [win.width, win.height], "engine_in_file": bpy.context.scene.render.engine})
    # Cycles for the material previews (as stage 1 sets lips.blend's): EEVEE compiles them on llvmpipe for ~90 s,
    # blocking the window
    yield from retrying(lambda: setattr(bpy.context.scene.render, "engine", "CYCLES"))
    for other in bpy.context.view_layer.objects:
        other.select_set(other == obj)
    bpy.context.view_layer.objects.active = obj
    space.show_region_ui = True
    sidebar = region_of(view, "UI")
    with bpy.context.temp_override(window=win, area=view, region=region_of(view)):
        bpy.ops.view3d.view_axis(type="FRONT")
        bpy.ops.view3d.view_selected()
    props_area.spaces.active.context = "MATERIAL"
    for window_area in win.screen.areas:
        window_area.tag_redraw()
    yield 4.0
    CHARACTER["areas"] = {a.type: [a.x, a.y, a.width, a.height] for a in win.screen.areas}
    CHARACTER["sidebar"] = list(x11_rect(sidebar))
    # The VTO tab (read-only in Python: active_panel_category): a real click on the sidebar's last tab.
    grab("character_tabs", sidebar)
    yield from click_at(*last_tab(sidebar, "character_tabs"))
    for _ in range(40):
        yield 0.05
        if region_of(view, "UI").active_panel_category == "VTO":
            break
    CHARACTER["sidebar_tab"] = region_of(view, "UI").active_panel_category
    log("sidebar tab", CHARACTER["sidebar_tab"])
    if CHARACTER["sidebar_tab"] != "VTO":
        raise RuntimeError(f"the click on the sidebar's last tab chose {CHARACTER['sidebar_tab']!r}, not VTO")
    xdo("mousemove", view.x + 40, window().height - (view.y + 40))  # the pointer off the sidebar
    yield 2.0
    grab("character_before", sidebar)
    views_docs("character_before", view)

    # 1. Find Face on Mesh: a real click on the sidebar's first button; done when the mesh has vto_lips.
    x, y = yield from panel_button(view, "UI", "character_before", nth(0, 1))
    yield from click_at(x, y)
    clicked = time.time()
    while "vto_lips" not in head().data.attributes:
        if time.time() - clicked > FIND_WAIT_S:
            raise RuntimeError(f"Find Face on Mesh wrote no vto_lips in {FIND_WAIT_S:g} s")
        yield 0.1
    CHARACTER["find_face_s"] = round(time.time() - clicked, 2)
    log(f"Find Face on Mesh done {CHARACTER['find_face_s']} s after the click")
    mesh = head().data
    counts = {}
    for name in ("vto_lips", "vto_eyelids"):
        values = np.empty(len(mesh.vertices), np.float32)
        mesh.attributes[name].data.foreach_get("value", values)
        counts[name] = int((values > 0.5).sum())
    CHARACTER["counts"] = counts
    CHARACTER["attributes"] = sorted(a.name for a in mesh.attributes if a.name.startswith("vto_"))
    active = mesh.color_attributes.active_color
    CHARACTER["active_color"] = active.name if active is not None else None
    CHARACTER["shading"] = {"type": space.shading.type, "color_type": space.shading.color_type}
    camera = bpy.data.objects.get(f"VTO Face Camera {head().name}")
    CHARACTER["camera"] = camera.name if camera is not None else None
    CHARACTER["thumbnail_icon"] = int(extension("ui.preview").found_face(head().name)[0])
    for window_area in win.screen.areas:
        window_area.tag_redraw()
    yield 3.0
    grab("character_found", sidebar)
    views_docs("character_found", view)

    # 2. The layers: Add Lipstick Layer, then Add Eye Shadow Layer (the sidebar's last two buttons, in that order).
    x, y = yield from panel_button(view, "UI", "character_found_buttons", nth(-2, 3))
    yield from click_at(x, y)
    for _ in range(100):
        yield 0.1
        if "lipstick" in worn():
            break
    else:
        raise RuntimeError("the click on Add Lipstick Layer added no layer")
    log("lipstick layer added")
    x, y = yield from panel_button(view, "UI", "character_lipstick_added", nth(-1, 3))
    yield from click_at(x, y)
    for _ in range(100):
        yield 0.1
        if "eyeshadow" in worn():
            break
    else:
        raise RuntimeError("the click on Add Eye Shadow Layer added no layer")
    log("eye shadow layer added")
    CHARACTER["layers"] = list(worn())
    CHARACTER["defaults"] = {name: layer_inputs(name) for name in worn()}
    chosen = extension("matching.apply").material_product(skin())
    CHARACTER["chosen_first"] = chosen.name if chosen is not None else None

    # 3. The reference, typed into the skin material's Match from photo panel (as stage 2 sets its own), then Match
    # (Fast) for the eye-shadow layer, Lipstick in the Fill row, Match again.
    yield from retrying(lambda: setattr(skin_props(), "image_path", bpy.path.relpath(EYES_REF)))
    with bpy.context.temp_override(window=win, area=props_area):
        bpy.ops.ed.undo_push(message="Reference")
    CHARACTER["reference"] = skin_props().image_path
    props_area.tag_redraw()
    xdo("mousemove", view.x + 40, window().height - (view.y + 40))  # the pointer off the sidebar's buttons
    yield 4.0
    x, y = yield from panel_button(props_area, "WINDOW", "character_eyes_before", tallest)
    yield from hover(x, y)
    values, ms = yield from click_match(skin_props, lambda: layer_inputs("eyeshadow"), "eye shadow layer")
    CHARACTER["eyeshadow"] = {"values": values, "ms": ms, "estimate": skin_props().last_estimate}
    CHARACTER["lipstick_after_eyeshadow_match"] = layer_inputs("lipstick")
    yield 1.0
    grab("character_eyes_matched", region_of(props_area))
    left, right, top, bottom = selected_buttons(region_of(props_area), "character_eyes_matched")[0]
    yield from click_at(left - 30, (top + bottom) // 2)  # Lipstick: the Fill row's button left of Eye Shadow
    for _ in range(40):
        yield 0.05
        if extension("matching.apply").material_product(skin()).name == "lipstick":
            CHARACTER["lipstick_chosen_by"] = "click"
            break
    else:
        RESULT["notes"].append("the click on Lipstick in the Fill row did not choose it")
        yield from retrying(lambda: extension("matching.apply").choose_layer(
            skin(), extension("matching.apply").get_product("lipstick")))
        CHARACTER["lipstick_chosen_by"] = "property"
    log("lipstick chosen by", CHARACTER["lipstick_chosen_by"])
    x, y = yield from panel_button(props_area, "WINDOW", "character_lips_before", tallest)
    yield from hover(x, y)
    values, ms = yield from click_match(skin_props, lambda: layer_inputs("lipstick"), "lipstick layer")
    CHARACTER["lipstick"] = {"values": values, "ms": ms, "estimate": skin_props().last_estimate}
    CHARACTER["eyeshadow_after_lipstick_match"] = layer_inputs("eyeshadow")
    yield 1.0
    grab("character_lips_matched", region_of(props_area))

    # 4. Material Preview, through the face camera (Rendered in Cycles, at a few samples, where EEVEE shows nothing).
    camera = bpy.data.objects[CHARACTER["camera"]]
    bpy.context.scene.camera = camera
    space.shading.type = "MATERIAL"
    space.region_3d.view_perspective = "CAMERA"
    with bpy.context.temp_override(window=win, area=view, region=region_of(view)):
        bpy.ops.view3d.view_center_camera()
    xdo("mousemove", view.x + 40, window().height - (view.y + 40))
    started = time.time()
    done = yield from settled(view, "character_matched", 180.0, region_of(props_area))
    if not done:
        RESULT["notes"].append("Material Preview showed no eye shadow in 180 s: Rendered (Cycles) instead")
        bpy.context.scene.cycles.preview_samples = 8
        space.shading.use_scene_world_render = False  # the head's .blend has no lights: the studio light's world
        space.shading.use_scene_lights_render = False
        space.shading.type = "RENDERED"
        done = yield from settled(view, "character_matched", 90.0, region_of(props_area))
    CHARACTER["preview"] = {"shading": space.shading.type, "seconds": round(time.time() - started, 1),
                            "settled": done, "purple_pixels": purple_pixels("character_matched", view)}
    # For the docs: the sidebar hidden, the camera's frame (16:9, as the scene renders) beside the Properties editor.
    space.show_region_ui = False
    viewport = region_of(view)
    frame = 560  # px: the frame's width; fits the viewport's width at view_camera_zoom's fit (view_center_camera)
    zoom_fac = frame / viewport.width  # BKE_screen_view3d_zoom_to_fac: ((sqrt(2) + zoom / 50) ** 2) / 4
    r3d = space.region_3d
    r3d.view_camera_zoom = ((4 * zoom_fac) ** 0.5 - 2 ** 0.5) * 50
    shift = viewport.width / 2 - 24 - frame / 2  # the frame's centre this far right of the viewport's
    r3d.view_camera_offset = (-shift / (2 * frame), 0.0)  # (measured: an offset of -0.1 moves it 0.2 frames right)
    view.tag_redraw()
    yield 3.0
    grab("character_matched_framed", region_of(props_area))
    left = x11_rect(viewport)[0] + round(viewport.width / 2 + shift - frame / 2) - 24
    top = area_rect(view)[1]
    p_left, p_top, p_width, p_height = area_rect(props_area)
    crop("character_matched_framed", "character_matched_docs", left, top, p_left + p_width - left,
         p_top + p_height - top)
    CHARACTER["completed"] = True


if __name__ == "__main__":  # (Blender runs a --python script as __main__)
    gui.run(script(), "stage3", shown=("character", "errors", "notes"), stall_s=FIND_WAIT_S + 60)
