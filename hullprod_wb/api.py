"""Public entry point: assess a hull given as a file, a FreeCAD object, a Part shape or a mesh.

The two numerical realizations are never converted into each other: a BRep is integrated
natively, a triangle mesh through discrete curvature (paper section 4).
"""
import os

from .core.constants import DEFAULT_HF, DEFAULT_KF
from .core.errors import InputError
from .core.inputs import file_representation


def representation_of(source):
    """'brep' or 'mesh' for a path, FreeCAD object, Part.Shape, Mesh.Mesh, trimesh or arrays."""
    if isinstance(source, (str, os.PathLike)):
        return file_representation(source)  # and its structure checked
    from .brep.reading.record_reader import ReadInChild
    if isinstance(source, ReadInChild):  # a BRep file's reading process
        return "brep"
    if type(source).__module__.startswith("trimesh") or isinstance(source, tuple):
        return "mesh"
    tname = type(source).__name__
    if hasattr(source, "Topology") and hasattr(source, "Facets"):  # FreeCAD Mesh.Mesh (MeshObject)
        return "mesh"
    if hasattr(source, "Mesh") and not hasattr(source, "Shape"):  # FreeCAD Mesh::Feature
        return "mesh"
    if hasattr(source, "Shape") or hasattr(source, "Faces"):
        return "brep"
    raise InputError("cannot assess an object of type %s: give a file path, a FreeCAD object with a "
                     "Shape or Mesh, a Part.Shape, or a triangle mesh" % tname)


def assess(source, lref=None, h_f=DEFAULT_HF, k_f=DEFAULT_KF, backend=None, faces=None,
           with_fields=True, progress=None, object_name=None, **options):
    """Compute the producibility signature of source.

    source: path (.stl .obj .ply .igs .iges .step .stp .brep), FreeCAD document object,
    Part.Shape, Mesh.Mesh, trimesh.Trimesh or (vertices, faces). lref: reference length
    in the input's units (None: automatic). h_f, k_f: class tolerances. backend: 'brep',
    'mesh' or None (by representation). faces: 1-based BRep face numbers to assess.
    options: BRep settings (order, rtol, max_depth, protocol, point_budget, depth_limit: see
    brep.validity.budget.DEFAULT_QUADRATURE; jobs: worker processes for the faces, see
    core.processes). A FreeCAD document (.FCStd path): object_name (Name or Label) selects
    its object (document_input.document_object). Every file's structure is checked before a
    reader sees it (core.file_checks). Returns an Assessment.
    """
    rep = representation_of(source)
    if rep == "document":
        from .document_input import document_object
        with document_object(source, object_name) as (obj, record):
            result = assess(obj, lref=lref, h_f=h_f, k_f=k_f, backend=backend, faces=faces,
                            with_fields=with_fields, progress=progress, **options)
        result.input = {**(result.input or {}), **record, "representation": result.input.get("representation")}
        return result
    if object_name is not None:
        raise InputError("--object selects an object of a FreeCAD document (.FCStd); the input is a %s" % rep)
    if backend is not None and backend != rep:
        raise InputError(
            "the input is a %s and cannot be assessed by the %s backend: the two realizations are "
            "never converted into each other (tessellate or fit it yourself and assess the result)"
            % (rep, backend))
    if rep == "mesh":
        if faces:
            raise InputError("--faces selects BRep faces; the input is a triangle mesh")
        from .mesh.backend import assess_mesh
        return assess_mesh(source, lref=lref, h_f=h_f, k_f=k_f, with_fields=with_fields,
                           progress=progress)
    if isinstance(source, (str, os.PathLike)):
        # OpenCascade reads the file in a child, which sends its plain records while this
        # process loads numpy and the backend (brep.reading.record_reader); a reader that ends the
        # child is reported (core.errors.ReaderDied), and this process reads no file itself
        from .brep.reading.record_reader import ReadInChild
        source = ReadInChild(os.fspath(source), faces, with_fields, options.get("display_deflection"),
                             options.get("cache"))
    try:
        from .brep.backend import assess_brep
    except BaseException:
        if hasattr(source, "close"):
            source.close()
        raise
    return assess_brep(source, lref=lref, h_f=h_f, k_f=k_f, faces=faces, with_fields=with_fields,
                       progress=progress, **options)
