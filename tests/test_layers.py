"""The layers of DESIGN.md, read from the import statements of every module (functions' own imports included):
kernels and media import neither comparisons nor pipeline, comparisons does not import pipeline, and a study
imports no other study (what studies share is pipeline/studies/shared.py)."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def imported_modules(path: Path) -> set[str]:
    """Every module named by an import statement anywhere in the file (absolute imports; `from a import b` gives
    a and a.b, since b may be a module)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def modules_under(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def test_the_imports_are_read_from_function_bodies_too():
    source = ROOT / "pipeline" / "studies" / "compare.py"
    assert "pipeline.live.session_cost" in imported_modules(source)
    assert "comparisons.lab.codecs.check_codec_qs" in imported_modules(ROOT / "pipeline" / "studies" / "params.py")


def test_lower_layers_do_not_import_higher_ones():
    wrong = []
    for package, forbidden in (("kernels", ("comparisons", "pipeline")), ("media", ("comparisons", "pipeline")),
                               ("comparisons", ("pipeline",))):
        for path in modules_under(package):
            wrong += [f"{path.relative_to(ROOT)} imports {name}" for name in imported_modules(path)
                      if name.split(".")[0] in forbidden]
    assert not wrong, wrong


def test_a_study_imports_no_other_study():
    studies = {path.stem for path in (ROOT / "pipeline" / "studies").glob("*.py")} - {"__init__"}
    assert {"compare", "lab", "params", "shared"} <= studies
    wrong = []
    for name in sorted(studies - {"shared"}):
        path = ROOT / "pipeline" / "studies" / f"{name}.py"
        for module in imported_modules(path):
            parts = module.split(".")
            if parts[:2] == ["pipeline", "studies"] and len(parts) > 2 and parts[2] in studies - {"shared", name}:
                wrong.append(f"{name} imports {module}")
    assert not wrong, wrong


def test_kernels_holds_what_its_docstring_lists():
    """kernels/ is deform and raster: each of its public modules is named in kernels/__init__'s list (the Warp
    twins, kernels/*_warp.py, and the errors module are covered by its closing lines)."""
    import kernels
    listed = kernels.__doc__
    public = {path.stem for path in (ROOT / "kernels").glob("*.py")
              if not path.stem.startswith("_") and not path.stem.endswith("_warp") and path.stem != "errors"}
    assert {"skinning", "raster", "muscles"} <= public
    assert not [stem for stem in sorted(public) if f"kernels.{stem}" not in listed]
    assert "kernels/*_warp.py" in listed and "KernelError" in listed
