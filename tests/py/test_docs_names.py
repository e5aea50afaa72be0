"""The code names the documentation cites exist (docs/*.md and README.md).

Every inline code span (`...`) of those pages, and every `tubempc ...` command line of their fenced
code blocks, is classified by its form; a span of a known form must name something that exists:

- a file path (`cpp/include/tubempc/mpc/tube_mpc.hpp`, `docs/benchmarks/*.json`,
  `tubempc/io/scenario.hpp`, `tests/py/core/test_mpc.py::test_name`): the file (or glob) exists in the
  repository (an include path under cpp/include, a package path under python/), and a `::test`
  suffix names a function of that file;
- a Python name (`tubempc.scenario.build_scenario`, `tubempc._core.io.read_scenario`): it imports and
  resolves attribute by attribute;
- a C++ name (`mpc::Settings::horizon`, `tubempc::gravity::Shape`, `dynamics::kDefaultPositionTolerance`):
  each component is an identifier of the code (comments and strings removed) under cpp/ or python/src;
- a setting (`tube.update`, `mpc.kinematics = "exact"`, `identification.prior_memory = 1`, a bare
  `design_delay = 5`): a field of the configuration (the dataclasses of python/tubempc/config/ and the
  packaged python/tubempc/data/bennu_paper.toml), or an old spelling the configuration still names
  (RENAMED_FIELDS, RENAMED_VALUES, REMOVED_FIELDS, REPLACED_FIELDS); a quoted value is one of the
  values the configuration or the scenario file format knows;
- a scenario-file record (`model.kinematics`, `mpc.qp_solver`): a record of cpp/include/tubempc/io/scenario.hpp;
- a command (`tubempc run --from-campaign DIR`, `tubempc bench mpc --repeats 3`): the subcommand
  exists in `tubempc.cli.build_parser()` and each `--option` is one of its options (for `bench NAME`,
  of that benchmark's parser);
- a CMake option or environment variable (`TUBEMPC_INSTALL_PIQP`, `TUBEMPC_BUILD_DIR`): named in the
  build files, tools/ or the package;
- an identifier (`TubeMPC`, `RunRecord.applied`, `lyapunov_tube`, `LYAPUNOV_NO_MARGIN`): defined in the
  package (python/tubempc, its stubs), in the C++ code (comments and strings removed) or in the CMake files.

Spans of no such form (formulas, values, units, prose in code font) are not checked. The relative
targets of the pages' Markdown links must exist too. ALLOWED lists
the few words in code font that are not names of this project's code (other projects' names).
"""

from __future__ import annotations

import argparse
import functools
import glob
import importlib
import re
import tomllib
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

# Words in code font that name other projects' code or generic things, not this project's.
ALLOWED = frozenset(
    {
        # other projects' names
        "SimplicialLDLT",  # Eigen
        "PolyhedralGravityModel",  # Basilisk
        "updateTaskPeriod",
        "smallBodyNavEKF",
        "smallBodyNavUKF",
        "pinholeCamera",
        "piqp_header_only",  # piqp::piqp_header_only, PIQP's CMake target
        "cmeel.prefix",
        "operator",
        "std",
        "Eigen",
        "piqp",
        "chromium",
        "playwright",
        "libgtest-dev",
        "doxygen_headers",  # a ctest test name (CMakeLists.txt)
        "tubempcConfig.cmake",
        "WARN_NO_PARAMDOC",  # Doxygen settings
        "WARN_IF_UNDOCUMENTED",
        "WARN_IF_INCOMPLETE_DOC",
    }
)

_FILE_EXT = r"(?:hpp|cpp|h|py|pyi|toml|json|md|sh|txt|obj|tab|cmake|in|png|rst|cfg|yml|yaml|h5)"
_TOP_DIRS = ("cpp/", "python/", "tests/", "docs/", "tools/", "examples/", "cmake/", ".ci/")
_PY_ID = r"[A-Za-z_][A-Za-z0-9_]*"


# ---------------------------------------------------------------------------------------------------
# What the repository defines


def _read(path: Path) -> str:
    return path.read_text(encoding="utf-8", errors="replace")


def _cpp_code(text: str) -> str:
    """C++ text without its comments and string literals (which may name what the code no longer has)."""
    text = re.sub(r'R"\((.*?)\)"', " ", text, flags=re.S)
    text = re.sub(r'"(?:\\.|[^"\\\n])*"', " ", text)
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return re.sub(r"//[^\n]*", " ", text)


@functools.cache
def cpp_identifiers() -> frozenset[str]:
    words: set[str] = set()
    for folder in ("cpp/include", "cpp/src", "python/src"):
        for path in (ROOT / folder).rglob("*"):
            if path.suffix in (".hpp", ".cpp", ".h"):
                words.update(re.findall(_PY_ID, _cpp_code(_read(path))))
    return frozenset(words)


@functools.cache
def python_identifiers() -> frozenset[str]:
    words: set[str] = set()
    for path in (ROOT / "python" / "tubempc").rglob("*"):
        if path.suffix in (".py", ".pyi"):
            words.update(re.findall(_PY_ID, _read(path)))
    return frozenset(words)


@functools.cache
def config_fields() -> dict[str, frozenset[str]]:
    """Section -> field names: the packaged TOML's and the config dataclasses'."""
    import dataclasses

    from tubempc import config

    data = tomllib.loads(_read(ROOT / "python" / "tubempc" / "data" / "bennu_paper.toml"))
    fields: dict[str, set[str]] = {s: set(v) for s, v in data.items() if isinstance(v, dict)}
    for f in dataclasses.fields(config.Config):
        cls = f.type if isinstance(f.type, type) else getattr(config, str(f.type), None)
        if cls is not None and dataclasses.is_dataclass(cls):
            fields.setdefault(f.name, set()).update(g.name for g in dataclasses.fields(cls))
    for section, old in [*config.RENAMED_FIELDS, *config.REMOVED_FIELDS, *config.REPLACED_FIELDS]:
        fields.setdefault(section, set()).add(old)
    return {s: frozenset(v) for s, v in fields.items()}


@functools.cache
def config_values() -> frozenset[str]:
    """Every quoted word of the configuration package, the packaged TOML files and the C++ enums' names."""
    text = "".join(_read(path) for path in sorted((ROOT / "python" / "tubempc" / "config").glob("*.py")))
    for path in (ROOT / "python" / "tubempc" / "data").rglob("*.toml"):
        text += _read(path)
    for path in [*(ROOT / "cpp" / "src").rglob("*.cpp"), *(ROOT / "cpp" / "include").rglob("*.hpp")]:
        text += _read(path)
    return frozenset(re.findall(r"\"([^\"\n]*)\"", text))


@functools.cache
def scenario_records() -> frozenset[str]:
    """The records scenario.hpp names, `mpc.<field>` for each field of mpc::Settings::for_each_field and
    `model.<field>`, `truth.<field>` for each of dynamics::ModelParams' and io::BodyModel's."""
    from tubempc import _core

    text = _read(ROOT / "cpp" / "include" / "tubempc" / "io" / "scenario.hpp")
    named = re.findall(
        r"`((?:model|truth|propagator|mpc|reference|tube|mission|controller|navigation|actuators|abort)\.[a-z_A-Z0-9.]+)`",
        text,
    )
    body = [*_core.dynamics.ModelParams.field_names(), *_core.io.BodyModel.field_names()]
    tables = [f"mpc.{f}" for f in _core.mpc.Settings.field_names()]
    tables += [f"{m}.{f}" for m in ("model", "truth") for f in body]
    return frozenset([*named, *tables])


@functools.cache
def build_words() -> str:
    parts = [ROOT / "CMakeLists.txt", *sorted((ROOT / "cmake").glob("*")), *sorted((ROOT / "tools").glob("*"))]
    parts += [p for p in (ROOT / "python" / "tubempc").rglob("*.py")]
    this = Path(__file__).name
    parts += [p for p in (ROOT / "tests").rglob("*") if p.suffix in (".py", ".txt", ".cmake") and p.name != this]
    parts += [p for p in (ROOT / "docs").glob("*.py")]
    return "\n".join(_read(p) for p in parts if p.is_file())


@functools.cache
def cli_parsers() -> dict[str, argparse.ArgumentParser]:
    """Subcommand -> its parser; 'bench NAME' -> that benchmark's parser."""
    from tubempc import benchmarks, cli

    parser = cli.build_parser()
    out: dict[str, argparse.ArgumentParser] = {"": parser}
    for action in parser._actions:  # argparse keeps its subparsers here
        if isinstance(action, argparse._SubParsersAction):
            out.update(action.choices)
    for name in benchmarks.available():
        p = argparse.ArgumentParser(prog=f"tubempc bench {name}")
        benchmarks.load(name).add_arguments(p)
        out[f"bench {name}"] = p
    return out


# ---------------------------------------------------------------------------------------------------
# Checks by form: each returns None (exists), or what is missing


def check_path(span: str) -> str | None:
    path, _, test = span.partition("::")
    path = path.rstrip("/")
    candidates = [ROOT / path]
    if path.startswith("tubempc/"):
        candidates += [ROOT / "cpp" / "include" / path, ROOT / "python" / path]
    for c in candidates:
        hits = [Path(p) for p in glob.glob(str(c))] if any(ch in path for ch in "*?[") else [c] if c.exists() else []
        if hits:
            if test and not any(re.search(rf"def {re.escape(test)}\b", _read(h)) for h in hits if h.is_file()):
                return f"{test} in {path}"
            return None
    return path


def check_python(span: str) -> str | None:
    """None if the dotted name resolves; else the name (an old import path, which resolves with a
    DeprecationWarning, counts as missing: the pages cite the current one)."""
    name = re.sub(r"\(.*$", "", span)
    parts = name.split(".")
    module, obj = None, None
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        try:
            for i in range(len(parts), 0, -1):
                try:
                    module = importlib.import_module(".".join(parts[:i]))
                except ImportError:
                    continue
                obj, rest = module, parts[i:]
                break
            else:
                return name
            for attr in rest:
                if not hasattr(obj, attr):
                    return name
                obj = getattr(obj, attr)
        except DeprecationWarning:
            return f"{name} (an old import path)"
    return None


def check_cpp(span: str) -> str | None:
    name = re.sub(r"\(.*$", "", span)
    parts = [p for p in name.split("::") if p and p != "tubempc"]
    missing = [p for p in parts if p not in cpp_identifiers() and p not in ALLOWED]
    return name if missing else None


def check_setting(section: str, key: str, value: str | None) -> str | None:
    fields = config_fields()
    if section not in fields:
        return None  # not a configuration section: another form decides
    if key != "*" and key not in fields[section]:
        # `tube.lyapunov_tube`: a function of the module tubempc.<section>, not a setting
        return None if check_python(f"tubempc.{section}.{key}") is None else f"{section}.{key}"
    if value is not None and value not in config_values():
        return f'{section}.{key} = "{value}"'
    return None


def check_bare_setting(key: str, value: str | None) -> str | None:
    if not any(key in keys for keys in config_fields().values()):
        # a keyword argument (`position_tolerance=0`) rather than a setting
        return None if key in python_identifiers() or key in cpp_identifiers() else key
    if value is not None and value not in config_values():
        return f'{key} = "{value}"'
    return None


def check_command(line: str) -> str | None:
    words = line.replace("\\|", "|").split()
    if len(words) < 2:
        return None
    parsers = cli_parsers()
    sub = words[1]
    if sub.startswith("-"):
        key, options = "", words[1:]
    elif sub == "bench" and len(words) > 2 and not words[2].isupper():  # not `tubempc bench NAME`
        names = words[2].split("|")
        for n in names:
            if f"bench {n}" not in parsers:
                return f"tubempc bench {n}"
        key, options = f"bench {names[0]}", words[3:]
    elif sub in parsers:
        key, options = sub, words[2:]
    else:
        return f"tubempc {sub}"
    known = set(parsers[key]._option_string_actions) | set(parsers[""]._option_string_actions)
    for w in options:
        opt = w.split("=")[0].strip("[]|")
        if opt.startswith("--") and re.fullmatch(r"--[a-z][a-z0-9-]*", opt) and opt not in known:
            return f"tubempc {key} {opt}"
    return None


@functools.cache
def cmake_identifiers() -> frozenset[str]:
    parts = [ROOT / "CMakeLists.txt", *sorted((ROOT / "cmake").glob("*"))]
    parts += [p for d in ("examples", "tests/cpp", "python/src") for p in (ROOT / d).rglob("CMakeLists.txt")]
    return frozenset(w for p in parts if p.is_file() for w in re.findall(_PY_ID, _read(p)))


def check_identifier(span: str) -> str | None:
    if span in config_values():
        return None  # an option's value (`whitened_box`), a name the code reads as text
    parts = re.sub(r"\(.*$", "", span).split(".")
    for p in parts:
        if not (p in python_identifiers() or p in cpp_identifiers() or p in cmake_identifiers() or p in ALLOWED):
            return span
    return None


_SETTING = re.compile(rf"({_PY_ID})\.({_PY_ID}|\*)(?:\s*=\s*(\"[^\"]*\"|[-+0-9.e]+|true|false))?")
_BARE_SETTING = re.compile(rf"({_PY_ID})\s*=\s*(\"[^\"]*\"|[-+0-9.e]+|true|false)")


def check_span(span: str) -> str | None:
    """None if the span is of no checked form or names something that exists; else what is missing."""
    s = span.strip()
    if not s or s in ALLOWED or "<" in s or s.startswith(("-", "$")):
        return None
    if s.startswith("tubempc ") or s.startswith(".venv/bin/tubempc "):
        return check_command(s.removeprefix(".venv/bin/"))
    if s.startswith("TUBEMPC_") and re.fullmatch(r"TUBEMPC_[A-Z0-9_]+", s.split("=")[0]):
        name = s.split("=")[0]
        return None if name in build_words() else name
    first = s.split()[0]
    if "/" in first and " " not in s and (first.startswith(_TOP_DIRS) or re.search(rf"\.{_FILE_EXT}(::{_PY_ID})?$", first)):
        if first.startswith(("http", "/")) or first.startswith("build/") or first.startswith("results/"):
            return None
        if first.startswith(("tubempc/", *_TOP_DIRS)) or "/" in first:
            return check_path(first)
    if re.fullmatch(rf"{_PY_ID}\.(py|pyi|hpp|cpp|h|sh|cmake|md)", s):  # a source file by its name
        return None if any(p for p in ROOT.glob(f"**/{s}") if "build" not in p.relative_to(ROOT).parts[:1]) else s
    if re.fullmatch(rf"tubempc(\.{_PY_ID})+(\(.*\))?", s):
        return check_python(s)
    if re.fullmatch(rf"({_PY_ID}::)+{_PY_ID}(\(.*\))?", s):
        return check_cpp(s)
    m = _SETTING.fullmatch(s)
    if m:
        section, key, value = m.group(1), m.group(2), m.group(3)
        quoted = value[1:-1] if value and value.startswith('"') else None
        if f"{section}.{key}" in scenario_records():
            return None  # a scenario-file record (mpc.* and tube.* are also configuration sections)
        if section in config_fields():
            return check_setting(section, key, quoted)
        if re.fullmatch(r"(model|truth|propagator|mpc|reference|tube|mission)", section):
            return None if key == "*" else f"{section}.{key}"
        if value is None and section[0].isupper():
            return check_identifier(s)
        return None
    m = _BARE_SETTING.fullmatch(s)
    if m:
        value = m.group(2)
        return check_bare_setting(m.group(1), value[1:-1] if value.startswith('"') else None)
    if re.fullmatch(rf"{_PY_ID}(\.{_PY_ID})?(\(.*\))?", s) and (
        "_" in s or re.search(r"[a-z][A-Z]|^[A-Z][a-z]+[A-Z]", s) or re.fullmatch(r"[A-Z][A-Z0-9_]+", s)
    ):
        if re.fullmatch(r"[A-Z][A-Z0-9_]+", s) and "_" not in s:
            return None  # an acronym in code font (PIQP, KKT), not a name
        return check_identifier(s)
    return None


# ---------------------------------------------------------------------------------------------------
# Extraction


def cited_spans(text: str) -> list[tuple[int, str]]:
    """(line, span): the inline code spans outside fenced blocks and the `tubempc` lines inside them."""
    out: list[tuple[int, str]] = []
    fence = False
    for no, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith(("```", "~~~")):
            fence = not fence
            continue
        if fence:
            cmd = line.split("#")[0].strip()
            for part in re.split(r"&&|;", cmd):
                part = part.strip()
                if part.startswith(("tubempc ", ".venv/bin/tubempc ")):
                    out.append((no, part))
            continue
        for m in re.finditer(r"(?<!`)`([^`\n]+)`(?!`)", line):
            span = m.group(1)
            if span.startswith("tubempc ") and "&&" in span:  # a chain of commands: each one checked alone
                out.extend((no, part.strip()) for part in span.split("&&"))
            else:
                out.append((no, span))
    return out


def linked_files(text: str) -> list[tuple[int, str]]:
    """(line, target): the relative link targets of the page's Markdown links (anchors dropped)."""
    out = []
    for no, line in enumerate(text.splitlines(), 1):
        for m in re.finditer(r"\]\(([^)\s]+)\)", line):
            target = m.group(1).split("#")[0]
            if target and not re.match(r"[a-z]+:", target):
                out.append((no, target))
    return out


def missing_names(path: Path) -> list[str]:
    """'<file>:<line>: `<span>`: no <what>' for every cited name and linked file that does not exist."""
    shown = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
    text = _read(path)
    missing = [
        f"{shown}:{no}: `{span}`: no {what}" for no, span in cited_spans(text) if (what := check_span(span)) is not None
    ]
    missing += [f"{shown}:{no}: link: no {t}" for no, t in linked_files(text) if not (path.parent / t).exists()]
    return missing


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_cited_name_exists(page: Path) -> None:
    missing = missing_names(page)
    assert not missing, "names cited in the docs that the code does not have:\n" + "\n".join(missing)


EXISTING = [
    "tubempc.scenario.build_scenario",
    "tubempc._core.io.read_scenario",
    "mpc::Settings::horizon",
    'tube.update = "lyapunov"',
    "design_delay = 5",
    "cpp/include/tubempc/mpc/tube_mpc.hpp",
    "tubempc/io/scenario.hpp",
    "tubempc run --seed 0",
    "tubempc bench mpc --repeats 3",
    "TubeMPC",
    "RunRecord.applied",
    "TUBEMPC_INSTALL_PIQP",
    "tests/py/core/test_mpc.py::test_shrinking_phase_qps_have_clarabels_optimum",
    "model.kinematics",
]
REMOVED = [
    "mpc::Backend::ActiveSetPiqp",
    "mpc::Settings::reuse_linearization",
    "tubempc.scenario.no_such_function",
    "tube.no_such_field",
    'mpc.kinematics = "no_such_value"',
    "no_such_setting = 3",
    "cpp/include/tubempc/mpc/no_such_header.hpp",
    "tubempc run --no-such-option",
    "tubempc nosuchcommand",
    "tubempc bench mpc --no-such-option",
    "NoSuchClass",
    "RunRecord.no_such_field",
    "TUBEMPC_NO_SUCH_OPTION",
    "tests/py/core/test_mpc.py::test_no_such_test",
    "model.no_such_record",
]


def test_the_check_passes_existing_names_and_catches_removed_ones(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text(
        "Some text with "
        + ", ".join(f"`{s}`" for s in EXISTING + REMOVED)
        + ".\n\n```bash\ntubempc sweep --lambda-p 0.9 --out d\ntubempc sweep --no-such-flag\n```\n"
        + f"[a link]({ROOT / 'docs' / 'model.md'}#frames), [another](no_such_page.md), [web](https://example.org)\n",
        encoding="utf-8",
    )
    flagged = [m.split(": ", 1)[1] for m in missing_names(page)]
    flagged = [f.split(": no ", 1)[0].strip("`") if f.startswith("`") else f for f in flagged]
    assert flagged == [*REMOVED, "tubempc sweep --no-such-flag", "link: no no_such_page.md"]
