"""HTML report: valid, self-contained, with decodable PNG maps; rendered to a picture."""
import base64
import io
import os
import shutil
import struct
import subprocess
from html.parser import HTMLParser

import numpy as np
import pytest

from conftest import needs_freecad

pytestmark = needs_freecad

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class Page(HTMLParser):
    """Collects tags (checking that every opened non-void tag is closed in order), image
    sources, headings and text."""

    VOID = {"meta", "img", "br", "hr", "link", "input"}

    def __init__(self):
        super().__init__()
        self.stack, self.images, self.headings, self.text, self.errors = [], [], [], [], []
        self.rows = []  # table rows as lists of cell texts
        self._in_h = None
        self._cell = None

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs))
        if tag == "tr":
            self.rows.append([])
        if tag in ("td", "th"):
            self._cell = []
        if tag not in self.VOID:
            self.stack.append(tag)
        if tag in ("h1", "h2", "h3"):
            self._in_h = []

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append("unexpected </%s> (open: %s)" % (tag, self.stack[-3:]))
            return
        self.stack.pop()
        if tag in ("td", "th") and self._cell is not None:
            self.rows[-1].append("".join(self._cell).strip())
            self._cell = None
        if tag in ("h1", "h2", "h3") and self._in_h is not None:
            self.headings.append("".join(self._in_h))
            self._in_h = None

    def handle_data(self, data):
        self.text.append(data)
        if self._cell is not None:
            self._cell.append(data)
        if self._in_h is not None:
            self._in_h.append(data)


def parse(text):
    p = Page()
    p.feed(text)
    p.close()
    assert not p.errors, p.errors[:3]
    assert p.stack == [], p.stack
    return p


def png_size(data):
    """(width, height) from a PNG's IHDR chunk; asserts the signature."""
    assert data[:8] == PNG_SIGNATURE
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def decode_images(page):
    out = []
    for img in page.images:
        src = img["src"]
        assert src.startswith("data:image/png;base64,"), src[:40]  # embedded, no external file
        out.append(base64.b64decode(src.split(",", 1)[1], validate=True))
    return out


@pytest.fixture(scope="module")
def mesh_assessment():
    from hullprod_wb.api import assess
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    return assess(half_wigley_mesh(48, 12), lref=1.0)


@pytest.fixture(scope="module")
def brep_assessment():
    from hullprod_wb.api import assess
    from hullprod_wb.examples.builtin import half_wigley_shape
    # coarse quadrature: the report, not the integral, is under test here
    return assess(half_wigley_shape(), lref=1.0, order=4, max_depth=2, rtol=1e-3)


@pytest.fixture(scope="module")
def studies(brep_assessment):
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    from hullprod_wb.examples.builtin import half_wigley_shape
    from hullprod_wb.studies import (refinement_study, representation_study, sameface_study,
                                     threshold_study)
    shape = half_wigley_shape()
    return [sameface_study(shape, levels=(12, 24)),
            refinement_study(meshes=[half_wigley_mesh(16 * k, 4 * k) for k in (1, 2, 4)], lref=1.0),
            representation_study(shape, lref=1.0, brep_assessment=brep_assessment),
            threshold_study(half_wigley_mesh(32, 8), lref=1.0)]


def test_mesh_report_is_valid_html_with_maps(tmp_path, mesh_assessment):
    from hullprod_wb.studies import write_report
    path = write_report(mesh_assessment, str(tmp_path / "r" / "report.html"))
    text = open(path, encoding="utf-8").read()
    page = parse(text)
    assert "Signature" in page.headings and "Maps" in page.headings and "Mesh quality" in page.headings
    # each metric's own row of the signature table carries its own status and value
    header = next(r for r in page.rows if r[:3] == ["metric", "value", "status"])
    signature = {r[0]: r for r in page.rows if len(r) == len(header)}
    from hullprod_wb.core.constants import METRIC_LABELS, METRICS
    for m in METRICS:
        row = signature[METRIC_LABELS[m]]
        rec = mesh_assessment.validity[m]
        assert row[2] == rec.status.value, (m, row)
        assert row[1] == ("-" if rec.value is None else "%.8g" % rec.value), (m, row)
    images = decode_images(page)
    assert len(images) == 2  # density and class maps
    for data in images:
        w, h = png_size(data)
        assert w >= 600 and h >= 200
    assert "src=\"http" not in text and "href=\"http" not in text  # self-contained


def test_brep_report_with_all_studies(tmp_path, brep_assessment, studies):
    from hullprod_wb.studies import write_report
    os.makedirs(tmp_path / "out")
    path = write_report(brep_assessment, str(tmp_path / "out"), studies=studies)  # a folder
    assert path.endswith(os.path.join("out", "report.html"))
    page = parse(open(path, encoding="utf-8").read())
    for h in ("Signature", "Maps", "Faces", "Provenance", "Same-face BRep-to-mesh curvature recovery",
              "Mesh-resolution sensitivity", "Representation: native BRep against triangle mesh",
              "Threshold study"):
        assert h in page.headings, h
    images = decode_images(page)
    assert len(images) == 3  # two maps and the same-face error plot
    for data in images:
        png_size(data)


def test_study_only_report_and_bad_input(tmp_path, studies):
    from hullprod_wb.core.errors import InputError
    from hullprod_wb.studies import report_html, write_report
    page = parse(report_html(None, studies[0]))
    assert "Same-face BRep-to-mesh curvature recovery" in page.headings
    # the headline row names the face of largest area with its finest-level figures
    head = next(r for r in page.rows if r and r[0].startswith("headline: largest area"))
    face = studies[0]["headline_face"]
    assert head[1] == str(face["face"])
    assert head[4] == "%.3f / %.3f" % (100 * face["eps_H"]["consistent"], 100 * face["eps_H"]["alternating"])
    assert any(r and r[0].startswith("largest |K| share") for r in page.rows)
    with pytest.raises(InputError):
        write_report(None, str(tmp_path / "x.html"))
    with pytest.raises(InputError):
        report_html(None, [{"study": "unknown"}])


def test_maps_render_invalid_samples_grey(mesh_assessment):
    """Boundary vertices of an open mesh are invalid: their triangles must be painted grey."""
    from matplotlib import colors
    from matplotlib.image import imread
    from hullprod_wb.studies.render import INVALID_COLOUR, render_class_map, triangle_class
    f = mesh_assessment.fields
    tc = triangle_class(f.class_id, f.triangles)
    assert (tc == -1).any() and (tc >= 2).any()
    img = imread(io.BytesIO(render_class_map(f)))
    grey = np.array(colors.to_rgb(INVALID_COLOUR))
    near = np.all(np.abs(img[..., :3] - grey) < 0.02, axis=-1)
    assert near.sum() > 100


def test_report_screenshot(tmp_path, mesh_assessment, studies):
    """Render one report page to PNG with headless Chromium when installed, else save the
    embedded maps; either way the picture must be a non-trivial PNG."""
    from hullprod_wb.studies import write_report
    path = write_report(mesh_assessment, str(tmp_path / "report.html"), studies=studies[1:2])
    shot = tmp_path / "report.png"
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if browser:
        subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                        "--window-size=1100,1600", "--screenshot=%s" % shot, "file://%s" % path],
                       capture_output=True, timeout=120, check=False)
    if not shot.exists():
        page = parse(open(path, encoding="utf-8").read())
        shot.write_bytes(decode_images(page)[0])
    data = shot.read_bytes()
    w, h = png_size(data)
    assert w >= 600 and h >= 200
    assert len(data) > 10000  # a blank page compresses to a few kB
