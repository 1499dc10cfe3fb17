"""The type stubs (brachia/__init__.pyi) say each thing once: no sentence of a docstring stands again in
another docstring of the stubs or of the package's Python modules, and every class and function they
declare is one the package has."""

import ast
import re
from collections import defaultdict
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "brachia"
STUBS = PACKAGE / "__init__.pyi"
#: Sentences shorter than this (``"Number of links n."``) may stand in two places.
SHORTEST = 25


def docstrings(path: Path) -> list[tuple[str, str]]:
    """(where, text) of every docstring of the module at ``path``: the module's, its classes' and
    functions', and those that follow a module-level annotated name (``SUCCESS_RADIUS_M``)."""
    tree = ast.parse(path.read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            text = ast.get_docstring(node, clean=True)
            if text:
                out.append((f"{path.name}:{getattr(node, 'name', '<module>')}", text))
    for a, b in zip(tree.body, tree.body[1:]):
        if (
            isinstance(a, ast.AnnAssign)
            and isinstance(b, ast.Expr)
            and isinstance(b.value, ast.Constant)
            and isinstance(b.value.value, str)
        ):
            out.append((f"{path.name}:{a.target.id}", b.value.value))
    return out


def sentences(text: str) -> list[str]:
    flat = re.sub(r"\s+", " ", text).strip()
    return [s.strip().lower() for s in re.split(r"(?<=[.;])\s+", flat) if len(s.strip()) >= SHORTEST]


def test_no_sentence_of_the_stubs_stands_twice():
    seen = defaultdict(list)
    for path in [STUBS, *sorted(PACKAGE.glob("*.py"))]:
        for where, text in docstrings(path):
            for s in sentences(text):
                seen[s].append(where)
    twice = {s: w for s, w in seen.items() if len(w) > 1}
    assert not twice, "\n".join(f"{w}: {s}" for s, w in twice.items())


def test_the_check_finds_a_repeated_sentence(tmp_path):
    # the same detector on two docstrings that share a sentence
    f = tmp_path / "m.py"
    f.write_text(
        'class A:\n    """One thing. The plant refuses every use but reset from then on."""\n'
        'class B:\n    """Another. The plant refuses every use but reset from then on."""\n'
    )
    found = defaultdict(list)
    for where, text in docstrings(f):
        for s in sentences(text):
            found[s].append(where)
    assert [w for w in found.values() if len(w) > 1] == [["m.py:A", "m.py:B"]]


def test_every_class_and_function_of_the_stubs_is_the_packages():
    init = ast.parse((PACKAGE / "__init__.py").read_text())
    exported = {a.asname or a.name for n in ast.walk(init) if isinstance(n, ast.ImportFrom) for a in n.names}
    stub = ast.parse(STUBS.read_text())
    declared = [n.name for n in stub.body if isinstance(n, (ast.ClassDef, ast.FunctionDef))]
    assert declared and set(declared) <= exported, sorted(set(declared) - exported)
