"""What a mutant can affect, so that its run reuses what it cannot change (tests/mutation/run.py).

Two questions, answered from the unmutated tree's sources (``ast``, nothing imported):

* **Can the mutant change compiled code?** numba freezes a kernel's globals and its callees when
  it compiles. A file that defines no kernel and that no kernel-defining file imports
  (transitively, package ``__init__`` files included) feeds no kernel, so a mutant there may run
  on the unmutated tree's compiled kernels. Every other mutant compiles from an empty cache.
* **Which tests can see the mutant?** coverage.py records which tests execute each line. That
  holds only for lines that run as Python inside a function: the lines of compiled functions
  (``@kernel``, ``@leaf`` — a leaf also runs as Python, but its calls from kernels are not seen —
  ``njit`` …), and lines at module or class level or in a signature (they run at import, under
  whichever test imports first) select the target's full tests (``None``).

A mutant's tests stop at the first failure, so they run quickest first (:func:`fastest_first`).
"""
from __future__ import annotations

import ast
import difflib
import importlib.util
import re
from collections.abc import Mapping
from pathlib import Path

PACKAGES = ("rtctl", "drivers", "hil_sim")  # as in rtctl/kernel_cache.py: the packages that hold kernels
JIT = {"kernel", "leaf", "njit", "jit", "register_jitable", "intrinsic", "overload", "overload_method",
       "overload_attribute", "generated_jit", "vectorize", "guvectorize", "cfunc", "stencil"}
_JIT_MODULES = ("numba", "rtctl.compiled")


def module_name(rel: Path) -> str:
    """``rtctl/guard/kernels.py`` → ``rtctl.guard.kernels``; ``rtctl/guard/__init__.py`` → ``rtctl.guard``."""
    parts = list(rel.with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def package_files(tree: Path) -> dict[str, Path]:
    """Every module of the packages in ``tree``: dotted name → path relative to ``tree``."""
    files = {}
    for pkg in PACKAGES:
        for path in sorted((tree / pkg).rglob("*.py")):
            rel = path.relative_to(tree)
            if "__pycache__" not in rel.parts and not any(p.startswith(".") for p in rel.parts):
                files[module_name(rel)] = rel
    return files


def _imported(tree_ast: ast.AST, here: str, is_package: bool, modules: set[str]) -> set[str]:
    """Dotted names of the modules an import anywhere in the file reads from (absolute or
    relative): ``import a.b`` → a, a.b (``as c``: a.b); ``from a import b`` → a.b if that is a module, else a."""
    names = set()
    package = here if is_package else here.rpartition(".")[0]
    for node in ast.walk(tree_ast):
        if isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                names.update(".".join(parts[:i]) for i in range(len(parts) if alias.asname else 1, len(parts) + 1))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            subs = {f"{mod}.{a.name}" for a in node.names}
            names.update(subs & modules)
            if subs - modules:  # (a name defined in ``mod`` itself)
                names.add(mod)
    return names


def _root(node: ast.AST) -> str | None:
    """``self`` for ``self.inner.x``."""
    while isinstance(node, ast.Attribute):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


def _patches_modules(tree_ast: ast.AST) -> bool:
    """Whether the file may rebind another module's globals (``mod.X = …``, ``setattr(obj, …)``
    on anything but ``self``): then it may change a kernel without being imported by one."""
    bound = set()
    for node in ast.walk(tree_ast):
        if isinstance(node, ast.Import):
            bound.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            bound.update(a.asname or a.name for a in node.names)
    for node in ast.walk(tree_ast):
        targets = node.targets if isinstance(node, ast.Assign) else \
            [node.target] if isinstance(node, (ast.AugAssign, ast.AnnAssign)) else []
        if any(isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name) and t.value.id in bound
               for t in targets):
            return True
        if isinstance(node, ast.Call) and _callee(node) == "setattr" and node.args and _root(node.args[0]) != "self":
            return True
    return False


def _callee(node: ast.AST) -> str | None:
    """The name a decorator or call invokes: ``kernel``, ``kernel(...)``, ``numba.njit(...)`` → njit."""
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return None


def _jit_functions(tree_ast: ast.AST) -> list[ast.AST]:
    """The function definitions numba compiles: decorated with a JIT name, or passed to one."""
    passed = {a.id for node in ast.walk(tree_ast) if isinstance(node, ast.Call) and _callee(node) in JIT
              for a in node.args if isinstance(a, ast.Name)}
    return [node for node in ast.walk(tree_ast)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and (any(_callee(d) in JIT for d in node.decorator_list) or node.name in passed)]


def defines_kernels(tree_ast: ast.AST) -> bool:
    """Whether the file imports numba or rtctl.compiled (or a name from either) and compiles a function."""
    imports = {node.module or "" for node in ast.walk(tree_ast) if isinstance(node, ast.ImportFrom)}
    imports |= {a.name for node in ast.walk(tree_ast) if isinstance(node, ast.Import) for a in node.names}
    imports |= {f"{node.module}.{a.name}" for node in ast.walk(tree_ast)
                if isinstance(node, ast.ImportFrom) and node.module for a in node.names}
    jit_module = any(m == j or m.startswith(j + ".") or m.endswith("compiled") for m in imports for j in _JIT_MODULES)
    return jit_module and bool(_jit_functions(tree_ast))


def _kernel_graph(tree: Path) -> tuple[dict[str, Path], dict[str, set[str]], set[str]]:
    """(every module → its file, the modules each kernel-defining or module-rebinding file
    reaches by imports — itself included —, the rebinding ones)."""
    files = package_files(tree)
    imports, roots, patchers = {}, [], set()
    for name, rel in files.items():
        parsed = ast.parse((tree / rel).read_text(), str(rel))
        imports[name] = _imported(parsed, name, rel.name == "__init__.py", set(files)) & set(files)
        kernels, patches = defines_kernels(parsed), _patches_modules(parsed)
        if kernels or patches:
            roots.append(name)
        if patches:
            patchers.add(name)

    def reach(start: str) -> set[str]:
        seen, todo = set(), [start]
        while todo:
            name = todo.pop()
            if name not in seen:
                seen.add(name)
                todo.extend(imports[name] - seen)
        return seen

    return files, {r: reach(r) for r in roots}, patchers


def kernel_closure(tree: Path) -> set[str]:
    """Relative paths (``rtctl/guard/kernels.py``) of the files whose mutants may change compiled
    code: those defining a kernel (or rebinding other modules' names) and every in-package
    module they import, transitively."""
    files, reached, _ = _kernel_graph(tree)
    return {str(files[n]) for names in reached.values() for n in names}


def kernel_dependents(tree: Path) -> dict[str, list[str] | None]:
    """For each file of the kernel closure, the files whose cached kernels a mutant there may
    change: itself if it defines kernels, and every kernel-defining file that imports it,
    transitively (numba freezes a kernel's callees and globals, all reached through imports).
    ``None`` where a file that rebinds other modules' globals reaches it: any kernel may change."""
    files, reached, patchers = _kernel_graph(tree)
    dependents: dict[str, list[str] | None] = {}
    for name in {n for names in reached.values() for n in names}:
        if any(name in reached[p] for p in patchers):
            dependents[str(files[name])] = None
        else:
            dependents[str(files[name])] = sorted(str(files[r]) for r, names in reached.items()
                                                  if name in names and r not in patchers)
    return dependents


def cache_owners(cache: Path, tree: Path) -> dict[str, str]:
    """Each file under the kernel directory ``cache`` (its path relative to ``cache``) → the
    source file of ``tree`` whose functions it holds, by numba's own naming: a subdirectory per
    source directory, files named ``<module>.<qualname>-…``. A file of no known source is left out."""
    from numba.core.caching import _CacheLocator  # (only the runner imports numba here)

    by_dir: dict[str, dict[str, str]] = {}
    for rel in package_files(tree).values():
        subdir = _CacheLocator.get_suitable_cache_subpath(str(tree / rel))
        by_dir.setdefault(subdir, {})[rel.stem] = str(rel)
    owners = {}
    for path in cache.rglob("*"):
        entry = path.relative_to(cache)
        if path.is_file() and len(entry.parts) == 2:
            source = by_dir.get(entry.parts[0], {}).get(entry.name.split(".")[0])
            if source is not None:
                owners[str(entry)] = source
    return owners


def line_kinds(source: str) -> tuple[dict[int, int], set[int]]:
    """For one file: every line inside a function body → the first line of the innermost
    statement holding it (the line coverage.py records); and the lines of compiled functions."""
    tree_ast = ast.parse(source)
    first: dict[int, tuple[int, int]] = {}  # line → (span, first line) of the innermost statement
    bodies = set()
    for node in ast.walk(tree_ast):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            bodies.update(range(node.body[0].lineno, node.body[-1].end_lineno + 1))
        if isinstance(node, ast.stmt):
            span = node.end_lineno - node.lineno
            for line in range(node.lineno, node.end_lineno + 1):
                if line not in first or span < first[line][0]:
                    first[line] = (span, node.lineno)
    compiled = {line for fn in _jit_functions(tree_ast)
                for line in range(min([fn.lineno, *(d.lineno for d in fn.decorator_list)]), fn.end_lineno + 1)}
    return {line: first[line][1] for line in bodies if line in first}, compiled


def changed_lines(pristine: str, mutated: str) -> set[int]:
    """The pristine file's lines (1-based) that the mutant rewrote (an insertion: the line after)."""
    a, b = pristine.splitlines(), mutated.splitlines()
    lines = set()
    for tag, i1, i2, _, _ in difflib.SequenceMatcher(None, a, b, autojunk=False).get_opcodes():
        if tag != "equal":
            lines.update(range(i1 + 1, max(i2, i1 + 1) + 1))
    return lines


def select_tests(pristine: str, mutated: str, covered: dict[int, list[str]]) -> set[str] | None:
    """The tests that execute the mutant's lines (``covered``: statement's first line → test ids
    from the unmutated run), or None where coverage cannot tell: the full tests."""
    in_body, compiled = line_kinds(pristine)
    selected = set()
    for line in changed_lines(pristine, mutated):
        if line in compiled or line not in in_body or not covered.get(in_body[line]):
            return None
        selected.update(covered[in_body[line]])
    return selected or None


def lines_to_tests(data_file: Path, tree: Path, files: list[str], order: list[str]) -> dict[str, dict[int, list[int]]]:
    """From a coverage data file written with pytest-cov's ``--cov-context=test`` (contexts
    ``<test id>|setup``, ``|run``, ``|teardown``; the empty context is the import at collection):
    file → line → the indices in ``order`` of the tests that executed it."""
    from coverage import CoverageData

    index = {t: i for i, t in enumerate(order)}
    data = CoverageData(basename=str(data_file))
    data.read()
    covered = {}
    for rel in files:
        by_line = data.contexts_by_lineno(str(tree / rel))
        covered[rel] = {line: sorted({index[c.split("|")[0]] for c in contexts if c.split("|")[0] in index})
                        for line, contexts in by_line.items()}
    return covered


def tree_cache_key(tree: Path, environ: Mapping[str, str]) -> str:
    """What rtctl.kernel_cache names the copy's kernel directory after in a process with
    ``environ``, from the copy's own module (loaded alone: importing rtctl would choose a directory)."""
    spec = importlib.util.spec_from_file_location("_copy_kernel_cache", tree / "rtctl" / "kernel_cache.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.cache_key([tree / p for p in module.PACKAGES if (tree / p).is_dir()], environ)


_DURATION = re.compile(r"^(\d+(?:\.\d+)?)s (?:setup|call|teardown)\s+(\S.*)$")


def fastest_first(order: list[str], durations_report: str) -> list[str]:
    """``order`` (test ids) with the quickest first, from pytest's ``--durations=0`` report of
    the unmutated run: the files by their total time, and in each file its tests by their own
    (setup, call and teardown; a test the report leaves out: 0 s). A file's tests stay
    together, so its module fixtures are set up once; ties keep the suite's order."""
    seconds: dict[str, float] = {}
    for line in durations_report.splitlines():
        m = _DURATION.match(line.strip())
        if m:
            seconds[m.group(2)] = seconds.get(m.group(2), 0.0) + float(m.group(1))
    per_file: dict[str, float] = {}
    for test in order:
        per_file[test.split("::")[0]] = per_file.get(test.split("::")[0], 0.0) + seconds.get(test, 0.0)
    return sorted(order, key=lambda t: (per_file[t.split("::")[0]], seconds.get(t, 0.0)))
