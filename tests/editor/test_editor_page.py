"""The load-case editor in real headless Chromium, on a part sliced by real PrusaSlicer and on its STL.

Each test starts the real ``loadpath edit`` command and drives its page the way a user does (clicks
on the part's holes and edges, typing, keyboard only); the saved file is checked with
``loadpath run`` and against the same case written by hand, resolved by ``loadpath.loadcase``.
"""

from __future__ import annotations

import dataclasses
import re
import subprocess

import numpy as np
import pytest
from editor_fixtures import LOADPATH, set_viewport, wait_for
from loadpath import gcode, geometry, loadcase

pytestmark = [pytest.mark.slow, pytest.mark.real_tool("chromium")]

# The bracket of tests/slicing.py (60 x 40 x 3, legs 15 wide, 5 mm hole at 52.5, 7.5 of the part),
# which the shared MK3S presets place at x 95..155, y 85..125 on the bed.
HAND_GCODE = """version = 1
[[supports]]
name = "wall"
where = { side = "y_max", within = 0.5 }
fix = ["x", "y"]
[[loads]]
name = "bolt"
where = { hole_near = [147.5, 92.5], radius = 2.0 }
force = [0.0, -500.0, 0.0]
[toolpath]
replace = ["sparse"]
"""
HAND_STL = """version = 1
frame = "part"
[[supports]]
name = "wall"
where = { side = "x_min", within = 0.5 }
fix = ["x", "y"]
[[loads]]
name = "bolt"
where = { hole_near = [52.5, 7.5], radius = 2.0 }
force = [0.0, -500.0, 0.0]
"""


# ------------------------------------------------------------------------------------------ helpers
def _open(drv, ed):
    drv.get(ed.url)
    wait_for(
        drv,
        "document.body.dataset.ready === '1' && document.body.dataset.resolved === '1'",
        60,
        "the page to load",
    )


def _settled(drv, timeout=30):
    wait_for(drv, "document.body.dataset.resolved === '1'", timeout, "the server's answer")


def _type(drv, elem, text):
    from selenium.webdriver.common.keys import Keys

    elem.click()
    elem.send_keys(Keys.CONTROL, "a")
    elem.send_keys(text, Keys.TAB)


def click_at(drv, x, y):
    """A real mouse click at viewport coordinates (px)."""
    from selenium.webdriver.common.action_chains import ActionChains

    chain = ActionChains(drv)
    chain.w3c_actions.pointer_action.move_to_location(int(round(x)), int(round(y)))
    chain.w3c_actions.pointer_action.click()
    chain.perform()


def _click_feature(drv, kind, label_part=None):
    """Click the middle of a hole or edge on the drawing, where a user would."""
    from selenium.webdriver.common.by import By

    feats = drv.find_elements(By.CSS_SELECTOR, f"#g-{kind}s .feature")
    if label_part is not None:
        feats = [f for f in feats if label_part in f.get_attribute("aria-label")]
    assert feats, f"no {kind} {label_part or ''} on the page"
    x, y = drv.execute_script(
        """
        const g = arguments[0], shape = g.querySelector('polygon, polyline.edge-hit');
        let p;
        if (shape.tagName === 'polygon') {
            const b = shape.getBBox(); p = new DOMPoint(b.x + b.width / 2, b.y + b.height / 2);
        } else {
            const q = shape.getPointAtLength(shape.getTotalLength() / 2); p = new DOMPoint(q.x, q.y);
        }
        const s = p.matrixTransform(shape.getScreenCTM());
        return [s.x, s.y];""",
        feats[0],
    )
    click_at(drv, x, y)
    assert "picked" in feats[0].get_attribute("class")


def _errors(drv):
    return drv.execute_script(
        "return [...document.querySelectorAll('.error')].filter(e => !e.hidden).map(e => e.textContent)"
    )


def _item(drv, key):
    from selenium.webdriver.common.by import By

    return drv.find_element(By.CSS_SELECTOR, f'[data-item="{key}"]')


def _build_case(drv, hole_load_name, edge_label, support_name):
    """Click the hole, 500 N bearing load pointing -y; click the edge, fix it (x and y)."""
    from selenium.webdriver.common.by import By

    _click_feature(drv, "hole")
    drv.find_element(By.ID, "as-load").click()
    load = _item(drv, "loads/0")
    _type(drv, load.find_element(By.CSS_SELECTOR, "input.name"), hole_load_name)
    _type(drv, load.find_element(By.CSS_SELECTOR, "input.magnitude"), "500")
    _type(drv, load.find_element(By.CSS_SELECTOR, "input.direction"), "-90")
    _click_feature(drv, "edge", edge_label)
    drv.find_element(By.ID, "as-support").click()
    sup = _item(drv, "supports/0")
    _type(drv, sup.find_element(By.CSS_SELECTOR, "input.name"), support_name)
    assert sup.find_element(By.CSS_SELECTOR, "input.fix-x").is_selected()
    assert sup.find_element(By.CSS_SELECTOR, "input.fix-y").is_selected()
    _settled(drv)
    assert _errors(drv) == []
    assert drv.execute_script("return editorState.c.loads[0].force") == [0, -500, 0]
    # each selection is drawn as the server resolved it
    assert drv.find_elements(By.CSS_SELECTOR, '#g-selections [data-item="loads/0"] polyline')
    assert drv.find_elements(By.CSS_SELECTOR, '#g-selections [data-item="supports/0"] polyline')


def _solve(drv, timeout):
    from selenium.webdriver.common.by import By

    drv.find_element(By.ID, "solve").click()
    wait_for(drv, "document.body.dataset.solved === '1'", timeout, "the solve")
    assert _errors(drv) == [], _errors(drv)
    n_cells = len(drv.find_elements(By.CSS_SELECTOR, "#g-stress rect"))
    n_bars = len(drv.find_elements(By.CSS_SELECTOR, "#g-stress line"))
    n_paths = len(drv.find_elements(By.CSS_SELECTOR, "#g-paths polyline"))
    # the new paths as printed: a linked layer may be one or two runs, so count their vertices
    n_vertices = drv.execute_script(
        "return [...document.querySelectorAll('#g-paths polyline')]"
        ".reduce((n, p) => n + p.points.numberOfItems, 0)"
    )
    counts = (n_cells, n_bars, n_paths, n_vertices)
    assert n_cells > 100 and n_bars > 100 and n_paths >= 1 and n_vertices > 50, counts


def _save(drv, ed):
    from selenium.webdriver.common.by import By

    drv.execute_script("document.body.dataset.saved = '0'")
    drv.find_element(By.ID, "save").click()
    wait_for(drv, "document.body.dataset.saved === '1'", 30, "the save")
    assert drv.find_element(By.ID, "status").text == f"Saved to {ed.case}"
    return ed.case.read_text(encoding="utf-8")


def _resolved(case_text, gcode_path):
    program = gcode.read(gcode_path)
    bodies = geometry.layer_geometry(program, check=False).bodies()
    return loadcase.resolve(loadcase.parse(case_text, "case.toml"), bodies)


def assert_same_resolution(a_text, b_text, gcode_path):
    """Two cases resolve to the same supports and loads: same boundary picked, same axes, same forces."""
    ra, rb = _resolved(a_text, gcode_path), _resolved(b_text, gcode_path)
    assert len(ra) == len(rb)
    for x, y in zip(ra, rb, strict=True):
        assert x.analysis == y.analysis
        assert len(x.supports) == len(y.supports) and len(x.loads) == len(y.loads)
        for (s1, p1), (s2, p2) in zip(x.supports + x.loads, y.supports + y.loads, strict=True):
            assert s1.name == s2.name
            assert getattr(s1, "fix", None) == getattr(s2, "fix", None)
            assert np.allclose(getattr(s1, "force", None) or 0, getattr(s2, "force", None) or 0)
            assert getattr(s1, "pressure", None) == getattr(s2, "pressure", None)
            assert p1.measure(x.analysis) == pytest.approx(p2.measure(y.analysis), rel=1e-9)
            assert p1.lines.symmetric_difference(p2.lines).length < 1e-6


def _run(gcode_path, case_path, out):
    r = subprocess.run(
        [str(LOADPATH), "run", str(gcode_path), "--loadcase", str(case_path), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr
    return r


# ---------------------------------------------------------------------------------------------- tests
def test_gcode_click_hole_and_edge_solve_save_run(browser, editor, prusa_bracket, tmp_path):
    from selenium.webdriver.common.by import By

    ed = editor(prusa_bracket, tmp_path / "bracket.toml")
    assert "new case" in ed.banner
    _open(browser, ed)
    _build_case(browser, "bolt", "side y_max", "wall")
    browser.find_element(By.ID, "tp-replace-sparse").click()  # replace the sparse infill too
    _settled(browser)
    _solve(browser, 600)
    rel = browser.find_element(By.ID, "relative-stiffness").text
    assert re.match(r"Predicted stiffness \d+\.\d{3}x the slicer's infill", rel), rel
    fail = browser.find_element(By.ID, "relative-failure-load").text  # the strength model's first-ply failure
    assert re.match(r"Predicted failure load \(first-ply failure\) \d+ N with the slicer's infill, \d+ N", fail), fail
    assert "layer" in browser.find_element(By.ID, "paths-note").text
    browser.find_element(By.ID, "show-slicer").click()  # the slicer's infill of the same layer beside it
    n_pts = browser.execute_script(
        "return [...document.querySelectorAll('#g-slicer polyline')].reduce((n, p) => n + p.points.length, 0)"
    )
    assert n_pts > 20  # PrusaSlicer's zig-zag of the replaced sparse layer
    saved = _save(browser, ed)
    assert 'frame = "bed"' in saved
    # the comments say what each selector picked on this part (the hole's centre, the edge's extent)
    assert re.search(
        r"\[\[loads\]\]\n# picks the hole at x 147\.[45]\d, y 92\.[45]\d \(4\.\d\d mm across\)", saved
    ), saved
    assert re.search(
        r"\[\[supports\]\]\n# picks 1[56]\.\d\d mm of outline in x 9[45]\.\d\d\.\.11\d\.\d\d, "
        r"y 124\.\d\d\.\.125\.00",
        saved,
    ), saved
    _run(prusa_bracket, ed.case, tmp_path / "out.gcode")
    assert_same_resolution(saved, HAND_GCODE, prusa_bracket)


def test_stl_click_hole_and_edge_solve_save_run(browser, editor, test_stls, prusa_bracket, tmp_path):
    (stl,) = test_stls("bracket")
    ed = editor(stl, tmp_path / "bracket-part.toml")
    _open(browser, ed)
    _build_case(browser, "bolt", "side x_min", "wall")
    _solve(browser, 300)
    saved = _save(browser, ed)
    assert 'frame = "part"' in saved
    assert "hole_near = [52.5, 7.5]" in saved
    # the case made on the STL fits the part wherever the slicer placed it
    _run(prusa_bracket, ed.case, tmp_path / "out.gcode")
    assert_same_resolution(saved, HAND_STL, prusa_bracket)


ROUND_TRIP = """version = 1
frame = "part"

[material]
youngs_modulus = 2010.0
poissons_ratio = 0.32

[[supports]]
name = "foot"
where = { x_max = 15.0, y_min = 30.0 }
fix = ["x", "y", "z"]

[[supports]]
name = "pin"
where = { hole_near = [52.5, 7.5], radius = 1.0 }
fix = ["y"]

[[loads]]
name = "push"
where = { side = "x_max", within = 2.0 }
pressure = -1.5

[[loads]]
name = "tip"
where = { x_min = 55.0, y_max = 15.0 }
force = [12.5, -300.0, 0.0]

[toolpath]
engine = "streamlines"
pitch = 0.5
principal = "tensile"
replace = ["solid", "sparse"]
"""


def test_open_then_save_keeps_the_meaning(browser, editor, test_stls, prusa_bracket, tmp_path):
    from selenium.webdriver.common.by import By

    (stl,) = test_stls("bracket")
    case = tmp_path / "case.toml"
    case.write_text(ROUND_TRIP, encoding="utf-8")
    ed = editor(stl, case)
    assert "opened" in ed.banner
    _open(browser, ed)
    names = [e.get_attribute("value") for e in browser.find_elements(By.CSS_SELECTOR, ".item input.name")]
    assert names == ["foot", "pin", "push", "tip"]
    assert browser.find_element(By.ID, "youngs").get_attribute("value") == "2010"
    assert _errors(browser) == []
    saved = _save(browser, ed)
    a, b = loadcase.parse(ROUND_TRIP), loadcase.parse(saved)
    assert dataclasses.replace(a, source="") == dataclasses.replace(b, source="")
    assert_same_resolution(ROUND_TRIP, saved, prusa_bracket)


def test_errors_are_inline_in_runs_words(browser, editor, test_stls, tmp_path):
    from selenium.webdriver.common.by import By

    (stl,) = test_stls("bracket")
    case = tmp_path / "case.toml"
    case.write_text(HAND_STL.replace("[52.5, 7.5]", "[30.0, 30.0]"), encoding="utf-8")
    ed = editor(stl, case)
    _open(browser, ed)
    err = _item(browser, "loads/0").find_element(By.CSS_SELECTOR, ".error")
    assert err.is_displayed()
    assert err.text.startswith(
        "case.toml: load 'bolt' (hole_near = [30.0, 30.0], radius = 2.0) selects no "
        "boundary of object 'bracket.stl'; the nearest hole is"
    )
    # a support that holds only x leaves the part free to slide in y: the solve says so by the supports
    _item(browser, "supports/0").find_element(By.CSS_SELECTOR, "input.fix-y").click()
    _item(browser, "loads/0").find_element(By.CSS_SELECTOR, ".delete").click()
    _click_feature(browser, "hole")
    browser.find_element(By.ID, "as-load").click()
    _settled(browser)
    assert _errors(browser) == []
    browser.find_element(By.ID, "solve").click()
    wait_for(browser, "document.body.dataset.solved === '1'", 300, "the solve")
    msg = browser.find_element(By.ID, "err-supports").text
    assert "is free to" in msg and "the supports ('wall') do not hold it" in msg, msg


def test_keyboard_alone_adds_a_support_and_a_load(browser, editor, test_stls, tmp_path):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    (stl,) = test_stls("bracket")
    ed = editor(stl, tmp_path / "k.toml")
    _open(browser, ed)

    def press(*keys):
        ActionChains(browser).send_keys(*keys).perform()

    def tab_to(target, back=False):
        for _ in range(120):
            if browser.execute_script("return document.activeElement && document.activeElement.id") == target:
                return
            if back:
                ActionChains(browser).key_down(Keys.SHIFT).send_keys(Keys.TAB).key_up(Keys.SHIFT).perform()
            else:
                press(Keys.TAB)
        raise AssertionError(f"Tab never reached #{target}")

    tab_to("feature")
    press(Keys.ARROW_DOWN)  # the first hole
    assert "hole 1" in browser.execute_script("return editorState.picked.label")
    tab_to("as-support")
    press(Keys.ENTER)
    _settled(browser)
    tab_to("feature", back=True)
    press(Keys.ARROW_DOWN)  # the first edge
    assert browser.execute_script("return editorState.picked.kind") == "edge"
    tab_to("as-load")
    press(Keys.ENTER)
    # focus is now in the new load: Tab to its force and type it
    for _ in range(20):
        if "magnitude" in browser.execute_script("return document.activeElement.className"):
            break
        press(Keys.TAB)
    press(Keys.CONTROL, "a")
    press("500", Keys.TAB)
    _settled(browser)
    c = browser.execute_script("return editorState.c")
    assert len(c["supports"]) == 1 and "hole_near" in c["supports"][0]["where"]
    assert len(c["loads"]) == 1 and np.hypot(*c["loads"][0]["force"][:2]) == pytest.approx(500)
    assert _errors(browser) == []


@pytest.mark.parametrize("size", [(1280, 800), (3840, 2160)])
def test_page_fits_the_screen_and_every_control_has_a_label(browser, editor, prusa_bracket, tmp_path, size):
    case = tmp_path / "bracket.toml"
    case.write_text(HAND_GCODE, encoding="utf-8")
    ed = editor(prusa_bracket, case)
    set_viewport(browser, *size)
    _open(browser, ed)
    shot = tmp_path / f"editor-{size[0]}x{size[1]}.png"
    browser.save_screenshot(str(shot))
    assert shot.stat().st_size > 10_000
    m = browser.execute_script("""
        const v = document.getElementById('view').getBoundingClientRect();
        const o = document.getElementById('g-outline').getBoundingClientRect();
        const unlabeled = [...document.querySelectorAll('input, select, button, textarea')].filter(e =>
            !((e.labels && e.labels.length) || e.getAttribute('aria-label')
              || e.getAttribute('aria-labelledby')
              || (e.tagName === 'BUTTON' && e.textContent.trim()))).map(e => e.outerHTML);
        const external = performance.getEntriesByType('resource').map(r => r.name)
            .filter(n => !n.startsWith(location.origin) && !n.startsWith('data:'));
        return {vw: v.width, vh: v.height, vx: v.left, ow: o.width, oh: o.height, ox: o.left, oy: o.top,
                scrollW: document.documentElement.scrollWidth, innerW: innerWidth, unlabeled, external,
                font: parseFloat(getComputedStyle(document.body).fontSize),
                selections: document.querySelectorAll('#g-selections polyline').length};
    """)
    assert m["unlabeled"] == []
    assert m["external"] == []
    assert m["scrollW"] <= m["innerW"]  # no sideways scrolling
    assert m["vw"] > 0.6 * size[0]
    # the part fills the drawing area (fit to the window, a margin left for the load arrows)
    assert max(m["ow"] / m["vw"], m["oh"] / m["vh"]) > 0.6
    assert m["ox"] >= m["vx"] and m["ox"] + m["ow"] <= m["vx"] + m["vw"] + 1
    assert m["selections"] >= 2
    assert m["font"] >= (18 if size[0] > 2400 else 13)


def _screen(drv, x, y):
    return drv.execute_script(
        "const p = new DOMPoint(arguments[0], arguments[1])"
        ".matrixTransform(document.getElementById('flip').getScreenCTM()); return [p.x, p.y];",
        x,
        y,
    )


def _drag(drv, a, b, steps=8):
    from selenium.webdriver.common.action_chains import ActionChains

    chain = ActionChains(drv)
    pa = chain.w3c_actions.pointer_action
    pa.move_to_location(int(a[0]), int(a[1]))
    pa.pointer_down()
    for k in range(1, steps + 1):
        pa.move_to_location(int(a[0] + (b[0] - a[0]) * k / steps), int(a[1] + (b[1] - a[1]) * k / steps))
    pa.pointer_up()
    chain.perform()


def test_drag_the_arrow_and_a_box_and_step_through_regions(browser, editor, test_stls, tmp_path):
    from selenium.webdriver.common.by import By

    (stl,) = test_stls("bracket")
    case = tmp_path / "case.toml"
    case.write_text(HAND_STL, encoding="utf-8")
    ed = editor(stl, case)
    _open(browser, ed)
    # the arrow of the 500 N load (pointing -y from the hole): drag its head to 1.5 times its length, +x
    hit = browser.find_element(By.CSS_SELECTOR, '#g-arrows [data-item="loads/0"] .arrow-hit')
    cx, cy = float(hit.get_attribute("cx")), float(hit.get_attribute("cy"))
    x0, y0 = 52.5, 7.5
    length = abs(cy - y0)
    _drag(browser, _screen(browser, cx, cy), _screen(browser, x0 + 1.5 * length, y0))
    _settled(browser)
    fx, fy, fz = browser.execute_script("return editorState.c.loads[0].force")
    assert fx == pytest.approx(750, rel=0.05) and abs(fy) < 1e-6 and fz == 0
    load = _item(browser, "loads/0")
    assert load.find_element(By.CSS_SELECTOR, "input.direction").get_attribute("value") == "0"
    # drag a box over the top of the short leg: a box selector, resolved by the server
    _drag(browser, _screen(browser, -3.0, 34.0), _screen(browser, 18.0, 43.0))
    assert browser.execute_script("return editorState.picked.kind") == "box"
    browser.find_element(By.ID, "as-support").click()
    _settled(browser)
    where = browser.execute_script("return editorState.c.supports[1].where")
    assert set(where) == {"x_min", "x_max", "y_min", "y_max"}
    assert where["x_min"] < 0 < 15 < where["x_max"] and where["y_min"] < 40 < where["y_max"]
    picked = _item(browser, "supports/1").find_element(By.CSS_SELECTOR, ".picked").text
    assert picked.startswith("bracket.stl: picks ") and "y 34." in picked, picked
    assert _errors(browser) == []


def test_parts_whose_outline_changes_get_a_region_slider(browser, editor, tmp_path):
    import slicing
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    stl = slicing.write_stl(slicing.tower_mesh(), tmp_path / "tower.stl")
    ed = editor(stl, tmp_path / "tower.toml")
    _open(browser, ed)
    slider = browser.find_element(By.ID, "layer")
    n = int(slider.get_attribute("max")) + 1
    assert n > 5 and slider.is_enabled()
    first = browser.find_element(By.ID, "layer-info").text
    outline0 = browser.find_element(By.CSS_SELECTOR, "#g-outline path").get_attribute("d")
    slider.send_keys(Keys.END)  # keyboard: the top region
    last = browser.find_element(By.ID, "layer-info").text
    assert first.startswith("z 0.00 to ") and last.endswith(f"(region {n} of {n})") and last != first
    assert browser.find_element(By.CSS_SELECTOR, "#g-outline path").get_attribute("d") != outline0
    assert browser.find_elements(By.CSS_SELECTOR, "#g-holes .feature")  # the twisted tower keeps its hole
