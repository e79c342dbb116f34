"""What the validity panel writes: areas with their unit, plates that are not established."""
from hullprod_wb.gui import wording


def test_the_i_d_denominator_reads_in_the_unit_of_the_area_beside_it():
    """A millimetre hull of 15.8672 m^2: the evidence's denominator (A_K) reads 15.8672 m^2,
    as the represented area does, not 1.58672e+07 without a unit."""
    ev = {"error_estimate": 3.6e-4, "numerator": 18.4, "denominator": 1.58672e7, "points": 4003998}
    text = wording.evidence_text(ev, "mm", 1.58672e7)
    assert "denominator = 15.8672 m\u00b2" in text
    assert wording.area_text(1.58672e7, "mm") == "15.8672 m\u00b2"
    assert "numerator = 18.4" in text and "points = 4003998" in text
    assert "denominator = 2.5 ft\u00b2" in wording.evidence_text({"denominator": 2.5}, "ft", 2.5)


def test_an_unconverged_plate_shows_no_number_and_is_explained():
    """An UNCONVERGED plate under a VALID* total: its I_D (9.63e+08) is not shown as a value,
    and the panel's note says why the total is established all the same."""
    faces = [{"face": 3, "status": "UNCONVERGED", "I_D": 9.63e8, "I_D_plus": 9.6e8, "a_C": {"flat": 0.1}},
             {"face": 4, "status": "VALID*", "I_D": 2.5}]
    assert wording.face_value(faces[0], "I_D") is None and wording.face_value(faces[0], "a_C") is None
    assert wording.format_value(wording.face_value(faces[0], "I_D")) == "\u2014"
    assert wording.face_value(faces[1], "I_D") == 2.5
    note = wording.unestablished_faces_note(faces, {"I_D": {"status": "VALID*"}})
    assert "Face3" in note and "Face4" not in note and "VALID*" in note and "error budget" in note
    assert wording.unestablished_faces_note(faces[1:], {"I_D": {"status": "VALID*"}}) == ""
