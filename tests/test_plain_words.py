"""What a person reads (panel texts, property descriptions, messages, the HTML report, CLI
help) carries no label of the paper's LaTeX source: the AST of every module, string
constants other than docstrings, checked against wording.PAPER_LABEL."""
import ast
import os

from hullprod_wb.gui.wording import PAPER_LABEL

PACKAGE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "hullprod_wb")


def shown_strings(tree):
    """(line, text) of the string constants of a module that are not docstrings."""
    docs = {id(n.body[0].value) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and n.body
            and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
    return [(n.lineno, n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs]


def test_the_pattern_finds_labels_and_passes_words():
    assert PAPER_LABEL.search("(paper eq:refs)") and PAPER_LABEL.search("100 eps_H c/a 6.6")
    assert PAPER_LABEL.search("as Table tab:publicsignatures") and PAPER_LABEL.search(r"see \ref{x}")
    assert not PAPER_LABEL.search(r"principal-axis span; k_f = 1e-4; I_D / L_ref^2; mm: 5720; [1-9]\d{2,}")


def test_no_source_label_in_a_shown_string():
    found = []
    for here, _, files in os.walk(PACKAGE):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(here, f)
                with open(path, encoding="utf-8") as fh:
                    tree = ast.parse(fh.read(), path)
                found += ["%s:%d %r" % (os.path.relpath(path, PACKAGE), line, text[:80])
                          for line, text in shown_strings(tree) if PAPER_LABEL.search(text)]
    assert found == []
