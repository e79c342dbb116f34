"""The workbench in the real FreeCAD GUI under Xvfb, in one FreeCAD session.

tests/gui_scripts/gui_checks.py runs inside `xvfb-run -a freecad`, drives every command
through FreeCADGui.runCommand and the panels' own buttons on a generated half-Wigley (BRep),
a generated mesh and, when ../shared/hulls is present, public hulls (DTMB 5415 as IGES, faces
1 and 2, and as STL; KVLCC2 for a long run and its Cancel; DTMB 5415 and KCS timed against
the command line), saves 3D-view and window screenshots and writes a JSON of what it saw;
the tests below assert on that JSON and on the PNG files. Refresh the pictures of
docs/gui.md with HULLPROD_UPDATE_SCREENSHOTS=1 /usr/bin/python3 -m pytest tests/test_gui.py
"""
import os
import shutil

import numpy as np
import pytest

from conftest import ROOT, SHARED_HULLS, gui_session

SCRIPT = os.path.join(ROOT, "tests", "gui_scripts", "gui_checks.py")
#: HULLPROD_UPDATE_SCREENSHOTS=1 writes the screenshots into docs/screenshots (the pictures
#: of docs/gui.md); otherwise into a temporary folder, so a test run leaves the tree clean.
UPDATE_DOCS = os.environ.get("HULLPROD_UPDATE_SCREENSHOTS") == "1"
DOC_SHOTS = os.path.join(ROOT, "docs", "screenshots")
#: One GUI session for all checks (about 2-3 minutes here with the public hulls, most of it
#: the long run and the command-line timings); the limit leaves room for a slow machine.
TIMEOUT = 900

needs_gui = pytest.mark.skipif(shutil.which("xvfb-run") is None or shutil.which("freecad") is None,
                               reason="xvfb-run or freecad not installed")
pytestmark = needs_gui

METRICS = ("I_D", "I_D+", "I_D-", "a_flat", "a_single", "a_elliptic", "a_saddle")
STATUSES = {"VALID", "VALID*", "CAUTION", "UNCONVERGED", "SINGULAR", "MESH-SENSITIVE", "NOT EVALUATED", "N/A"}


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    return DOC_SHOTS if UPDATE_DOCS else str(tmp_path_factory.mktemp("screenshots"))


@pytest.fixture(scope="module")
def gui(tmp_path_factory, shots):
    work = tmp_path_factory.mktemp("gui")
    res = gui_session(SCRIPT, work, TIMEOUT, HULLPROD_SCREENSHOTS=shots, HULLPROD_WORK=str(work),
                      HULLPROD_SHARED_HULLS=SHARED_HULLS if os.path.isdir(SHARED_HULLS) else "")
    assert not res["errors"], res["errors"]
    assert res["package"] == os.path.realpath(os.path.join(ROOT, "hullprod_wb")), (
        "FreeCAD loaded the workbench from %s, not from this checkout" % res["package"])
    return res


def step(gui, name):
    rec = gui["steps"][name]
    assert "exception" not in rec, rec["exception"]
    return rec


def png_stats(path):
    """(distinct 8-bit colours, fraction of non-white pixels) of a PNG."""
    import matplotlib.image as mpimg
    img = mpimg.imread(path)[..., :3]
    q = np.round(np.asarray(img, float) * 255).astype(np.int64)
    flat = q.reshape(-1, 3)
    distinct = len(np.unique(flat[:, 0] * 65536 + flat[:, 1] * 256 + flat[:, 2]))
    return distinct, float(np.mean(np.any(flat < 250, axis=1)))


def assert_not_blank(path, min_colors=20, min_ink=0.01):
    assert os.path.isfile(path), path
    distinct, ink = png_stats(path)
    assert distinct >= min_colors and ink >= min_ink, "%s looks blank: %d colours, %.3f ink" % (path, distinct, ink)


def assert_seen(rec, what):
    """An on_screen.seen_by_a_person record says a person sees the widget."""
    assert rec is not None, "%s: nothing recorded (no run going on?)" % what
    assert rec["seen"] is True, "%s is not seen on screen: %s\n%s" % (what, rec.get("why"), rec)
    assert rec["points"] and all(hit for _, _, hit in rec["points"]), rec


def block_means(img, b=4):
    """Grey level of img averaged over b x b blocks (sub-pixel shifts and the antialiasing
    of a fractional device pixel ratio average out)."""
    h, w = img.shape[0] // b * b, img.shape[1] // b * b
    return img[:h, :w].mean(axis=2).reshape(h // b, b, w // b, b).mean(axis=(1, 3))


def assert_panel_in_picture(gui, shots, name, min_corr=0.8):
    """The window screenshot `name` shows the panel as the panel itself paints: over its
    visible part the picture and the panel's own grab correlate (4-pixel block means,
    Pearson r >= min_corr; the 3D view in its place gives r near 0). The picture shows what
    a person sees, not the 3D view pasted over the panel."""
    import matplotlib.image as mpimg
    rec = gui["panel_in_shot"][name]
    shot_img = mpimg.imread(os.path.join(shots, name + ".png"))[..., :3]
    own = mpimg.imread(rec["grab"])[..., :3]
    (x, y, w, h), (ox, oy) = rec["rect"], rec["offset"]
    assert w > 50 and h > 50 and rec["scale"][0] == pytest.approx(rec["scale"][1], abs=0.01), rec
    crop, part = shot_img[y:y + h, x:x + w], own[oy:oy + h, ox:ox + w]
    hh, ww = min(crop.shape[0], part.shape[0]), min(crop.shape[1], part.shape[1])
    assert hh > 0.9 * h and ww > 0.9 * w, (crop.shape, part.shape, rec)
    a, b = (block_means(img[:hh, :ww]).ravel() for img in (crop, part))
    a, b = a - a.mean(), b - b.mean()
    r = float((a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum() + 1e-12))
    assert r >= min_corr, "%s: the picture does not show the panel where it is (r = %.2f)" % (name, r)


def test_on_screen_tells_hidden_covered_and_seen_widgets():
    """on_screen.seen_by_a_person in a plain Qt window: a page behind another tab, a button
    under an opaque frame and one under a small label at its centre are not seen; a free
    button and the page brought forward (bring_into_view) are."""
    from hullprod_wb.gui.qt import QtWidgets
    from hullprod_wb.gui.on_screen import bring_into_view, seen_by_a_person
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    win = QtWidgets.QWidget()
    win.resize(420, 320)
    tabs = QtWidgets.QTabWidget(win)
    tabs.setGeometry(0, 0, 200, 300)
    model, tasks = QtWidgets.QLabel("model"), QtWidgets.QLabel("tasks")
    tabs.addTab(model, "Model")
    tabs.addTab(tasks, "Tasks")
    under = QtWidgets.QPushButton("under", win)
    under.setGeometry(220, 20, 150, 80)
    cover = QtWidgets.QFrame(win)
    cover.setAutoFillBackground(True)
    cover.setGeometry(210, 10, 180, 100)
    spot = QtWidgets.QPushButton("spot", win)
    spot.setGeometry(220, 120, 150, 80)
    label = QtWidgets.QLabel("x", win)
    label.setGeometry(285, 150, 20, 20)
    free = QtWidgets.QPushButton("free", win)
    free.setGeometry(220, 220, 150, 80)
    win.show()
    for _ in range(20):
        app.processEvents()
    try:
        hidden, covered, centre = seen_by_a_person(tasks), seen_by_a_person(under), seen_by_a_person(spot)
        assert not hidden["seen"] and "hidden" in hidden["why"]
        assert not covered["seen"] and covered["why"]
        assert not centre["seen"] and "covered at 1 of 5 points" in centre["why"], centre
        assert seen_by_a_person(free)["seen"] and seen_by_a_person(model)["seen"]
        bring_into_view(tasks)
        app.processEvents()
        assert seen_by_a_person(tasks)["seen"] and not seen_by_a_person(model)["seen"]
        # another top-level window over the free button: not seen, unless other windows are let pass
        over = QtWidgets.QDialog()
        over.setGeometry(free.mapToGlobal(free.rect().center()).x() - 10,
                         free.mapToGlobal(free.rect().center()).y() - 10, 30, 30)
        over.show()
        for _ in range(20):
            app.processEvents()
        strict, lenient = seen_by_a_person(free), seen_by_a_person(free, other_windows_ok=True)
        over.close()
        assert not strict["seen"] and "QDialog" in strict["why"], strict
        assert lenient["seen"] and lenient["under"], lenient
    finally:
        win.close()
        win.deleteLater()


def test_gui_selftest_suite_in_the_session(gui):
    """TestHullProdGui (FreeCAD's Test workbench suite, hullprod_wb.gui.selftest) run in the
    GUI session: at least its 4 tests, none failing, none skipped (the GUI is up)."""
    rec = step(gui, "gui_selftest")
    assert rec["run"] >= 4 and rec["failures"] == 0 and rec["errors"] == 0, rec
    assert rec["skipped"] == 0, rec
    assert os.path.realpath(rec["file"]) == os.path.realpath(os.path.join(ROOT, "TestHullProdGui.py"))


def test_running_state_seen(gui):
    """While a run goes on (errors_and_cancel's long run, before Cancel) the progress bar and
    the task dialog's Cancel button are seen on screen."""
    rec = step(gui, "errors_and_cancel")["running_on_screen"]
    assert rec is not None, "the run ended before its first progress"
    assert_seen(rec["bar"], "the progress bar")
    assert_seen(rec["cancel"], "the Cancel button")


def test_long_run_keeps_the_gui_responsive_and_cancels(gui, shots):
    """OK on a long run (KVLCC2, rtol 1e-6, depth 6) with the view orbiting: the view redraws
    at least once a second; Cancel ends the assessment process within a second and the panel
    says so; no analysis is made and no error is reported."""
    rec = step(gui, "responsive_cancel")
    if "skipped" in rec:
        pytest.skip(rec["skipped"])
    assert rec["still_running"], "the run ended before Cancel (%s s): not a long run" % rec["run_seconds"]
    assert rec["run_seconds"] >= 10
    assert rec["redraws"] >= rec["run_seconds"] and rec["max_gap"] < 1.0, rec
    assert rec["cancel_seconds"] is not None and rec["cancel_seconds"] < 1.0, rec
    assert rec["message"].startswith("Cancelled"), rec["message"]
    assert rec["message_in_view"] == {"1600x1000": True, "1280x720": True}  # the line is not clipped
    assert rec["created"] == 0 and rec["errors"] == []
    assert rec["proposal"].startswith("automatic: ") and "computing" not in rec["proposal"]  # arrived meanwhile
    assert_seen(rec["running_on_screen"]["bar"], "the progress bar")
    assert_seen(rec["running_on_screen"]["cancel"], "the Cancel button")
    assert_not_blank(rec["png_running"])
    assert_panel_in_picture(gui, shots, "analyze_running")


@pytest.mark.parametrize("fname", ["dtmb5415_half_overture.igs", "kcs_full_closed_ohp.iges",
                                   "fcship_half_wavebem.iges"])
def test_gui_time_against_command_line(gui, fname):
    """GUI time of Analyze (OK until the analysis is shown) against `./hullprod analyze`,
    run alternately in the GUI session, both printed (a measurement, not a timed test: the
    ratio moves with the machine's load); the GUI's analysis is made, with a finite I_D. A
    hull the command line fails on is skipped, with its reason, if the GUI reports an error
    for it too."""
    rec = step(gui, "gui_vs_cli")[fname]
    if "skipped" in rec:
        pytest.skip(rec["skipped"])
    if rec["cli_error"]:
        assert rec["errors"], "the command line fails (%s) but the GUI did not" % rec["cli_error"]
        pytest.skip("the command line fails on %s: %s (GUI: %s)" % (fname, rec["cli_error"], rec["errors"][0]))
    assert not rec["errors"], rec["errors"]
    gui_s, cli_s = float(np.median(rec["seconds"])), float(np.median(rec["cli_seconds"]))
    print("\n%s: GUI %.2f s (runs %s), command line %.2f s (runs %s): %.2fx"
          % (fname, gui_s, ", ".join("%.2f" % x for x in rec["seconds"]), cli_s,
             ", ".join("%.2f" % x for x in rec["cli_seconds"]), gui_s / cli_s))
    for line in rec.get("timelines") or []:
        print("  GUI timeline (s): %s" % ", ".join("%s %.2f" % kv for kv in sorted((line or {}).items())))
    if rec.get("idle_cpu_share") is not None:
        print("  FreeCAD's process idle (event loop only): %.2f CPU s per s" % rec["idle_cpu_share"])
    for cpu in rec.get("gui_cpu") or []:
        print("  GUI CPU (s): worker and its face processes %.2f, FreeCAD's process %.2f" % (cpu["worker"], cpu["gui"]))
    for info in rec.get("cli_info") or []:
        print("  command line: CPU %.2f s, jobs %s, timings (s) %s" % (
            info["cpu"], info.get("jobs"), ", ".join("%s %.2f" % kv for kv in sorted((info.get("timings") or {}).items()))))
    assert rec["I_D"] is not None and np.isfinite(rec["I_D"]) and rec["lref"] > 0


def test_workbench_toolbar_menu_commands(gui):
    rec = step(gui, "workbench")
    assert rec["active"] == "HullProdWorkbench"
    assert "HullProd" in rec["toolbars"] and rec["has_menu"]
    assert all(rec["commands"].values()), rec["commands"]
    assert rec["toolbar_actions"] >= 9
    assert {"HullProd_Analyze", "HullProd_Probe", "HullProd_StudyThresholds"} <= set(rec["registered"])
    assert rec["icons"] == {"HullProd_Analyze": True, "preferences-hullprod": True}


def test_analyze_brep_through_panel(gui, shots):
    rec = step(gui, "analyze_wigley")
    assert rec["panel_shown"] and "automatic" in rec["proposal"] and "principal-axis" in rec["method"]
    assert rec["advanced_enabled"] is True  # BRep: quadrature settings offered
    assert rec["quadrature"] == [6, 2e-4, 4]  # the advanced settings reach the object
    # the command line's defaults (brep.budget.DEFAULT_QUADRATURE), each setting explained
    assert rec["quadrature_defaults"] == ["budget", 8000000, 30] and all(rec["quadrature_tips"])
    # each protocol shows its own settings: the maximum depth only under paper
    assert rec["protocol_rows"] == {"paper": ["maximum depth"], "budget": ["point budget", "depth limit"]}
    assert rec["budget_settings"] == ["budget", 2000000, 20]  # recorded on the analysis object
    assert rec["run_options"] == {"protocol": "budget", "point_budget": 2000000, "depth_limit": 20}  # and run with
    assert rec["no_selection_error"] and "select" in rec["no_selection_error"][0]
    assert rec["status"] == "ok" and rec["representation"] == "brep" and rec["lref"] == 1.0
    assert rec["I_D_status"] in STATUSES
    # Native BRep I_D of the half-Wigley with L_ref = L (paper Table tab:brepanalytic):
    # 4.30990339; the quadrature is asked for rtol 2e-4, 1e-3 leaves room for its estimate.
    assert rec["I_D"] == pytest.approx(4.30990339, rel=1e-3)
    assert rec["source_visible"] is False  # hidden (a view setting), not modified
    assert rec["selected_after"] == []  # no selection highlight tints the new map
    assert rec["precision_types"] == ["App::PropertyPrecision"] * 3  # shown with their digits, not "0.00"
    assert_seen(rec["on_screen"], "the Analyze panel")
    assert_not_blank(os.path.join(shots, "analyze_panel.png"))
    assert_panel_in_picture(gui, shots, "analyze_panel")


def test_colour_maps_one_colour_per_vertex(gui):
    rec = step(gui, "colour_maps_wigley")
    for mode, r in rec.items():
        assert r["mode"] == mode
        assert r["n_colors"] == r["n_points"] > 100, mode
        assert r["selected_after"] == [], mode  # the map's own colours, no selection tint
        assert_not_blank(r["png"])
    assert rec["Developability"]["distinct"] > 50 and rec["Signed"]["distinct"] > 50
    assert rec["Classes"]["distinct"] >= 2  # elliptic and saddle regions of the Wigley hull
    entries = rec["Classes"]["entries"]
    assert [e.split()[0] for e in entries] == ["invalid", "flat", "single", "elliptic", "saddle"]
    shares = [float(e.split()[1]) for e in entries]  # shares of the area in per cent
    assert all(e.endswith(" %") for e in entries) and sum(shares) == pytest.approx(100.0, abs=0.3)
    assert len(rec["Developability"]["ticks"]) == 5


def test_verification_menu_runs_a_study_and_writes_the_report(gui):
    rec = step(gui, "verification_menu")
    assert len(rec["commands"]) == 4
    assert not [m for m in rec["messages"] if m[0] == "error"], rec["messages"]
    assert rec["report"].endswith("HalfWigley_thresholds_study.html") and rec["html_bytes"] > 1000
    assert rec["has_threshold_table"]


def test_validity_panel(gui, shots):
    rec = step(gui, "validity_panel")
    rows = rec["rows"]
    assert [r[0] for r in rows] == list(METRICS)
    assert all(r[2] in STATUSES for r in rows)
    assert all(r[3].startswith(r[2] + ":") for r in rows)  # plain-language sentence per status
    for k, r in enumerate(rows):  # a sentence said once; a later metric with the same points to it
        if ": as for " in r[3]:
            named = r[3].split(": as for ", 1)[1].rstrip(".")
            assert any(q[0] == named and q[2] == r[2] and ": as for " not in q[3] for q in rows[:k]), (r, rows)
    assert len(set(rec["status_colors"])) >= 1 and all(c.startswith("#") for c in rec["status_colors"])
    assert {"backend", "file", "sha256", "units", "L_ref", "faces used", "software"} <= set(rec["provenance"])
    assert rec["face_rows"] and rec["face_rows"][0][0] == "Face1"
    assert rec["json_copied"] and rec["tree_top"] >= 5
    assert rec["legend_after_click"] == "curvature class (area)"
    assert all(rec["enabled_while_open"].values()), rec["enabled_while_open"]  # commands usable beside the panel
    assert rec["scale_before"] == ["Percentile", "Logarithmic"]
    assert rec["fixed_ticks"][0] == "1" and rec["fixed_ticks"][-1] == "1e+04"  # the preset reached the map
    assert "linear" in rec["linear_title"]
    assert "0.0743953 mm\u00b2" in rec["areas"] and "{" not in rec["units_row"]  # a 1 mm part: mm², not 7e-08 m²
    assert rec["reason_scrolls"] is False  # the reasons wrap instead of scrolling sideways
    assert_seen(rec["on_screen"], "the validity panel")
    assert_not_blank(rec["png"])
    assert_panel_in_picture(gui, shots, "validity_panel")


def test_probe_exact_on_brep(gui, shots):
    rec = step(gui, "probe_wigley")
    r = rec["result"]
    assert r is not None, "no hull under the probed pixel (tried %s)" % rec["tried"]
    assert r["exact"] is True and r["face"] == 1 and r["class_name"] == "elliptic"
    # The picked point lies on the display triangulation near the target (a pixel or two).
    assert np.allclose(r["point"], rec["target"], atol=0.01)
    assert r["K"] > 0 and r["q_D"] == pytest.approx(abs(r["K"]), rel=1e-12)  # L_ref = 1
    assert rec["rows"] == 1 and rec["callback_removed"] is True
    assert "K (1/mm\u00b2)" in rec["headers"] and "H (1/mm)" in rec["headers"]
    assert rec["marker_before"] > 0 and rec["marker_after"] == 0  # the marker goes with the panel
    assert_seen(rec["on_screen"], "the probe panel")
    assert_not_blank(rec["png"])
    assert_panel_in_picture(gui, shots, "probe_panel")


def test_mesh_analysis_and_interpolated_probe(gui):
    rec = step(gui, "mesh_analysis")
    assert rec["status"] == "ok" and rec["representation"] == "mesh"
    assert rec["advanced_enabled"] is False  # no quadrature for meshes
    c = rec["colors"]
    assert c["n_colors"] == c["n_points"] and c["distinct"] > 10
    assert rec["probe"]["exact"] is False and "interpolated" in rec["probe"]["method"]
    assert rec["unchanged"] is True
    # the plate view on a mesh says why it cannot be shown and leaves the map as it was
    assert rec["plates"]["map"] == "Developability" and "triangle mesh" in rec["plates"]["messages"][0]


def test_selected_faces_only(gui):
    rec = step(gui, "face_selection")
    assert rec["face_count"] == 3 and rec["faces"] == rec["faces_used"] == [rec["lateral"]]
    assert rec["a_single"][0] == pytest.approx(1.0, abs=1e-9)  # a cylinder is singly curved
    assert "Edge1" in rec["ignored"]  # the stray edge is named
    # the whole cylinder with 'leave out planar faces': the two caps are left out and recorded
    caps = sorted(set(range(1, rec["face_count"] + 1)) - {rec["lateral"]})
    assert rec["planar_faces_used"] == [rec["lateral"]] and rec["planar_recorded"] == caps
    assert rec["planar_property"] is True and rec["planar_text"] == "planar: " + ", ".join("Face%d" % f for f in caps)
    # a line is refused before a panel opens
    assert not rec["line_panel_opened"] and "has no faces" in rec["line_messages"][0]


def test_compare_flags_and_chart(gui):
    rec = step(gui, "compare")
    assert any("different representations" in f for f in rec["flags"])
    assert rec["columns"] == 2 and rec["rows"] >= 7 and rec["pixmap"]
    assert_not_blank(rec["chart"])
    assert_not_blank(rec["window"])


def test_export_files(gui):
    rec = step(gui, "export")
    assert rec["files"] == ["fields.csv", "fields.vtp", "signature.csv", "signature.json"]
    assert rec["info"] and "signature.json" in rec["info"][0]


def test_errors_and_cancel_never_crash(gui):
    rec = step(gui, "errors_and_cancel")
    assert rec["bad_created"] == 0 and any("L_ref" in e for e in rec["errors"])
    assert rec["cancel_created"] == 0 and rec["objects_unchanged"] and "Cancelled" in rec["cancel_message"]
    assert rec["compare_listed"] >= 2  # nothing selected: Compare lists every open analysis
    # Std_Delete removes an analysis; its source stays hidden while another analysis shows it.
    assert rec["deleted"] and rec["other_analyses"] >= 1 and rec["source_shown_after_delete"] is False


def test_real_hull(gui):
    rec = step(gui, "real_hull")
    if "skipped" in rec:
        pytest.skip(rec["skipped"])
    assert rec["status"] == "ok" and rec["unchanged"] is True and "automatic" in rec["proposal"]
    want = [int(f[4:]) for f in rec["selected"]] if rec["selected"] else list(range(1, rec["face_count"] + 1))
    assert rec["faces"] == want  # only the selected faces were assessed
    for mode, r in rec["shots"].items():
        assert r["n_colors"] == r["n_points"] > 100, mode
        assert_not_blank(r["png"])
    assert rec["shots"]["developability"]["distinct"] > 20
    assert rec["shots"]["classes"]["distinct"] >= 2


def test_real_mesh_hull(gui):
    rec = step(gui, "real_mesh_hull")
    if "skipped" in rec:
        pytest.skip(rec["skipped"])
    assert rec["status"] == "ok" and rec["unchanged"] is True
    for key in ("developability", "classes"):
        r = rec[key]
        assert r["n_colors"] == r["n_points"] > 1000
        assert_not_blank(r["png"])


def test_compare_real_hull_flags_reference_lengths(gui):
    rec = step(gui, "compare_real")
    if "skipped" in rec:
        pytest.skip(rec["skipped"])
    text = " ".join(rec["flags"])
    assert "different representations" in text and "L_ref differs" in text
    assert_not_blank(rec["window"])


def test_save_reload_restores_view_provider(gui):
    rec = step(gui, "save_reload_gui")
    assert rec["I_D_same"] and rec["vp_class"] == "ViewProviderHullProdAnalysis"
    assert rec["map"] == "Classes" and rec["colors"]["n_colors"] == rec["colors"]["n_points"]
    # a map button of a hidden analysis shows it, with its own colour bar
    after = rec["after_map_button"]
    assert after["visible"] is True and after["legend_on"] == [after["name"]]


def test_legend_fully_visible_beside_the_navigation_cube(gui):
    rec = step(gui, "legend_layout")
    for size in ("1600x1000", "1280x720"):
        for mode in ("Developability", "Classes", "Signed"):
            r = rec[size][mode]
            assert r["inside"] and not r["overlaps_cube"], (size, mode, r, rec[size]["view"])
        assert_not_blank(rec[size]["png"])


def shaded(rgb, s):
    return np.asarray(rgb, float) * s


@pytest.mark.parametrize("pair", [("flat", "invalid"), ("zero_signed", "invalid"), ("zero_developability", "invalid"),
                                  ("flat", "zero_signed")])
def test_flat_invalid_and_zero_read_as_distinct_colours_under_shading(pair):
    """Lit at any brightness between half and full, the colours of a flat class sample, an
    invalid sample and a zero (signed map: white; developability: the bottom of the ramp)
    stay apart (no brightness of one matches another within 0.12 in RGB)."""
    from hullprod_wb.gui import colormaps
    colours = {"flat": colormaps.CLASS_RGB["flat"], "invalid": colormaps.INVALID_RGB,
               "zero_signed": colormaps.ramp(np.array([0.5]), colormaps.DIVERGING)[0],
               "zero_developability": colormaps.developability_colors(np.array([0.0, 1.0, 10.0]), 1e-4)[0][0]}
    a, b = (np.asarray(colours[k], float) for k in pair)
    s = np.linspace(0.5, 1.0, 51)
    gap = min(np.linalg.norm(shaded(a, x) - shaded(b, y)) for x in s for y in s)
    assert gap > 0.12, (pair, gap)


def test_plates_colour_a_valid_zero():
    """A face with an established I_D of 0 takes the bottom colour of the ramp (marked
    '<= k_f' on the legend); a face without an established I_D takes the invalid colour."""
    from hullprod_wb.gui import colormaps
    rgb, legend = colormaps.plate_colors(np.array([1, 2, 3]), {1: 0.0, 2: 5.0, 3: None}, 1e-4)
    assert np.allclose(rgb[0], colormaps.ramp(np.array([0.0]))[0])
    assert np.allclose(rgb[2], colormaps.INVALID_RGB)
    assert not np.allclose(rgb[0], rgb[2]) and legend.ticks[0][1].startswith("<= k_f / ")


def test_scale_presets_linear_and_percentiles():
    """The default scale runs between two percentiles of the samples above k_f; a fixed range
    saturates outside; the linear scale maps proportionally."""
    from hullprod_wb.gui import colormaps
    q = np.concatenate([np.full(90, 1e-3), np.logspace(0, 4, 10)])
    lo, hi = colormaps.value_range(q, 1e-4)
    assert lo == pytest.approx(np.percentile(q, 10)) and hi == pytest.approx(np.percentile(q, 99.5))
    fixed = colormaps.Scale(range="Fixed", low=1.0, high=1e4)
    assert colormaps.value_range(q, 1e-4, fixed) == (1.0, 1e4)
    t = colormaps.scaled(np.array([0.1, 100.0, 1e5]), 1.0, 1e4, "Logarithmic")
    assert t.tolist() == [0.0, 0.5, 1.0]
    lin = colormaps.Scale(range="Fixed", kind="Linear", low=0.0, high=10.0)
    assert colormaps.scaled(np.array([2.5]), *colormaps.value_range(q, 1e-4, lin), "Linear")[0] == 0.25


def test_preferences_page(gui):
    rec = step(gui, "preferences")
    assert rec["stored"] == 2e-4 and rec["reloaded"] == "0.0001"


def test_plate_scale_starts_at_the_smallest_established_plate_above_k_f():
    """Plates at rounding (0) or numerically flat (1e-9, below k_f) take the bottom colour
    and do not set the scale: its low end is the smallest established plate above k_f (5),
    not 1e-9; an unconverged plate (None, however large its number) is not established."""
    from hullprod_wb.gui import colormaps
    values = {1: 0.0, 2: 1e-9, 3: 5.0, 4: 8.3e4, 5: None}
    rgb, legend = colormaps.plate_colors(np.array([1, 2, 3, 4, 5]), values, 1e-4)
    bottom = colormaps.ramp(np.array([0.0]))[0]
    assert np.allclose(rgb[0], bottom) and np.allclose(rgb[1], bottom) and np.allclose(rgb[2], bottom)
    assert np.allclose(rgb[3], colormaps.ramp(np.array([1.0]))[0])
    assert np.allclose(rgb[4], colormaps.INVALID_RGB)
    assert legend.ticks[0][1] == "<= k_f / 5" and legend.ticks[-1][1] == "8.3e+04"


def test_plate_map_low_end_and_no_invalid_sample_on_a_valid_face(gui):
    """On the fore body analysed in the GUI: no display sample of a VALID or VALID* face is
    NaN or invalid, none is drawn in the not-established colour under the developability or
    plate map; the plate map's low end is the smallest established face I_D above k_f, the
    plates at or below k_f marked as such; the I_D evidence names the unit of its
    denominator as the represented area beside it does."""
    from hullprod_wb.gui.wording import area_text
    rec = step(gui, "plates_low_end_and_samples")
    if "skipped" in rec:
        pytest.skip(rec["skipped"])
    assert rec["established"] > 0 and rec["samples_on_valid"] > 1000
    assert rec["bad_samples_on_valid"] == 0
    for mode, r in rec["drawn"].items():
        assert r["mauve_on_valid"] == 0, mode
        assert r["n_colors"] == r["n_points"]
        assert_not_blank(r["png"])
    low = rec["drawn"]["plates"]["ticks"][0]
    assert rec["at_or_below_k_f"] > 0 and low.startswith("<= k_f / ")
    assert float(low.split("/ ")[1]) == pytest.approx(rec["smallest_above_k_f"], rel=1e-3)
    line = rec["evidence_line"]
    assert "denominator = %s" % area_text(rec["denominator"], rec["unit"], rec["represented_area"]) in line
    assert area_text(rec["represented_area"], rec["unit"]) in line
    assert_seen(rec["evidence_seen"], "the evidence line of the validity panel")
    assert_not_blank(rec["png_validity"])


def test_probe_click_selects_nothing_and_warns_nothing(gui):
    """A person's click in probe mode adds a probe row; the hull is not selected (the
    selection colour would hide its map) and no RuntimeWarning is printed."""
    rec = step(gui, "probe_click_selects_nothing")
    assert rec["target_on_screen"], (rec["tried"], rec["viewport"])
    if rec["rows"] == 0 and rec["freecad"] >= [1, 1]:
        # FreeCAD 1.1's viewer does not pass a Qt mouse event sent from Python on to Coin's
        # event callbacks (tried on the GL viewport and the viewer around it)
        pytest.skip("a synthetic click does not reach the 3D view's Coin callbacks on FreeCAD %d.%d: %s"
                    % (rec["freecad"][0], rec["freecad"][1], rec["tried"]))
    assert rec["rows"] >= 1, rec["tried"]
    assert rec["selected"] == []
    assert rec["warnings"] == []
    assert rec["selectable_after_close"]


def test_fit_all_frames_a_hull_far_from_the_origin(gui):
    """The colour bar, drawn at the origin through its own camera, is out of the view's
    bounding box: a hull in ship coordinates fills the view after "fit all"."""
    rec = step(gui, "fit_all_frames_a_hull_far_from_the_origin")
    (lo, hi), (hlo, hhi) = rec["bbox"], rec["hull"]
    size = max(b - a for a, b in zip(hlo, hhi))
    assert all(abs(a - b) <= 1e-4 * size for a, b in zip(lo + hi, hlo + hhi)), rec
    assert max(rec["extent"]) >= 0.25, rec  # fit all leaves margins; with the origin framed too, 0.005
    assert_not_blank(rec["png"])


def test_legend_follows_the_remaining_analysis(gui):
    rec = step(gui, "legend_follows_remaining_analysis")
    assert rec["before"] == ["Hull1_analysis_3"] and rec["left"] == ["Hull1_analysis"]
    assert rec["visible"] and rec["legend"]
    assert rec["legend_nodes"] == 1 and rec["legend_switch"] != -1  # SO_SWITCH_NONE is -1


def test_compare_lists_analyses_of_every_open_document(gui):
    rec = step(gui, "compare_across_documents")
    assert rec["errors"] == []
    doc_a, doc_b = rec["documents"]
    assert rec["listed"] == rec["every_open"]  # every open document's analyses, those of other checks too
    assert doc_a + ": HullA_analysis" in rec["listed"] and doc_b + ": HullB_analysis" in rec["listed"]
    n = len(rec["listed"])  # one selected: all are ticked and compared
    assert rec["compared"] == rec["listed"] and rec["columns"] == n and rec["retabled"] == n
    assert any("L_ref differs" in f for f in rec["flags"])
    assert "two or more" in rec["note_one_ticked"]


@pytest.mark.parametrize("size", ["1280x720", "1600x1000"])
def test_panels_fit_the_default_combo_view(gui, size):
    """Every shown widget of the Analyze, validity, probe and compare panels ends inside the
    task view's visible width (or the task view scrolls sideways); the Analyze and validity
    panels fit without scrolling sideways, and the validity table's reasons (each on a row
    spanning the table) hold a phrase per line, not one word."""
    rec = step(gui, "panels_fit_and_speak_plainly")[size]
    for panel in ("analyze", "validity", "probe", "compare"):
        assert rec[panel] == [], (panel, rec["combo_width"])
    # the panels fit the combo view's width: nothing needs scrolling sideways to be read
    assert rec["validity_scrolls_sideways"] is False, rec["validity_scrolls_sideways"]
    assert rec["analyze_scrolls_sideways"] is False, rec["analyze_scrolls_sideways"]
    assert rec["reason_chars"] >= 24, rec


def test_one_colour_bar_when_a_macro_adds_an_analysis(gui):
    rec = step(gui, "panels_fit_and_speak_plainly")
    assert rec["legends_on"] == ["FitHull_analysis_2"]


def test_no_paper_label_in_what_the_gui_shows(gui):
    rec = step(gui, "panels_fit_and_speak_plainly")
    assert rec["texts_checked"] > 100
    assert rec["labels_seen"] == []


def study_step(gui):
    rec = step(gui, "study_in_process")
    if rec.get("skipped"):
        pytest.skip(rec["skipped"])
    assert rec["error"] is None, rec["error"]
    return rec


def test_study_does_not_block_the_event_loop(gui):
    """A threshold study runs in the assessment process: the command returns at once and
    the event loop never waits more than about a second while the study runs (KCS, 125
    faces, several seconds of work); its report is beside the saved document, titled after
    the hull, and Cancel ends a running study within a second, with no report."""
    rec = study_step(gui)
    assert rec["study_seconds"] > 2.0 and rec["progress_events"] >= 3, rec
    assert rec["command_returned_after"] < 1.0 and rec["longest_event_loop_gap"] < 1.0, rec
    assert rec["report"] == rec["expected_report"] and os.path.isfile(rec["report"])
    assert rec["report_title"] == "HullProd thresholds study: kcsstudy"
    assert rec["cancel_pressed_while_running"] and rec["cancel_seconds"] < 1.0, rec
    assert rec["cancelled_state"] == "cancelled" and rec["cancelled_report"] is None
    assert any("Cancelled" in m[2] for m in rec["cancel_messages"]), rec["cancel_messages"]


def test_threshold_study_row_equals_analyze(gui):
    """The study assesses what Analyze assessed (same source, same L_ref, same settings):
    its h_f = k_f = 1e-4 row has Analyze's I_D, I_D+, I_D- to 1e-9 and the same statuses."""
    rec = study_step(gui)
    assert rec["study_lref"] == rec["lref"]
    row = rec["rows"]["0.0001"]
    for m in ("I_D", "I_D_plus", "I_D_minus"):
        assert row[m] == pytest.approx(rec["analysis"][m], rel=1e-9), m
    assert row["status"] == rec["analysis_status"]
    assert set(row["status"].values()) <= STATUSES


def test_live_update_follows_the_source_in_the_background(gui, shots):
    """AutoUpdate on: an edit and a recompute return at once, the update runs in the
    background with the event loop ticking, and lands in place with the change of I_D and
    only the edited face integrated again; off: the recompute marks the results out of date;
    the source changed back: current again."""
    rec = step(gui, "live_update")
    assert rec["first_status"] == "ok" and rec["first_delta"] != rec["first_delta"]  # NaN: nothing before
    assert rec["after_toggle"] == {"status": "ok", "I_D": rec["first_I_D"], "running": False}
    assert rec["edit_recompute_s"] < 1.0 and rec["running"], rec
    assert rec["status_after_edit"].startswith("updating")
    assert rec["done"] and not rec["out_of_date"], rec
    assert rec["max_gap"] < 1.0 and rec["ticks"] > 5, rec
    assert rec["integrated"] == [5]  # the middle patch; the other eight from the store
    # the other eight faces' results and display samples from the store
    assert rec["cache"]["hits"] == 16 and rec["cache"]["faces_from_store"] == [1, 2, 3, 4, 6, 7, 8, 9]
    assert rec["delta"] == pytest.approx(rec["I_D"] - rec["first_I_D"], abs=1e-12) and rec["delta"] != 0
    assert rec["change_line"].startswith("Change against the previous result: I_D ")
    assert "Face5" in rec["change_line"] and "other 8 from the faces' store" in rec["change_line"]
    off = rec["off"]
    assert off["status"].startswith("out of date") and off["out_of_date"] and not off["running"]
    assert off["I_D"] == rec["I_D"] and off["recompute_s"] < 1.0
    assert rec["back"] == {"status": "ok", "out_of_date": False}
    emptied = rec["emptied"]
    assert emptied["status"].startswith("error: ") and "no faces" in emptied["status"], emptied
    assert emptied["I_D"] == rec["I_D"] and not emptied["running"]
    assert_not_blank(rec["png"])
    # the change map: the edited face stands out, the others stay near white (their shares move
    # only with the total area)
    change = {int(f): v for f, v in rec["change_map"].items()}
    assert rec["change_legend"] == "change of each face's share of I_D"
    assert max(change, key=change.get) == 5 and change[5] > 0.3
    assert all(v < 0.25 * change[5] for f, v in change.items() if f != 5), change
    assert_not_blank(rec["png_change"])
