"""The docs run: every fenced code block of README.md, docs/*.md and notebooks/README.md.

* Python blocks are executed, as written, from the repository root (``slow``);
* YAML blocks parse, and a block that is a whole config validates;
* shell blocks are checked line by line: a ``make`` target exists in the Makefile, a
  ``shapegrowth`` command line parses with the CLI's own parser and names files that exist,
  a script exists.  A shell block runs for minutes to hours (``make run``, a reproduction),
  so none is executed; each says why in a ``<!-- not run: REASON -->`` line above it.
* docs/LAYERS.md is generated from the package; no file cites a page the repository lacks;
  a shipped config is mostly keys.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml
from conftest import ROOT

DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "notebooks" / "README.md"]
NOT_RUN = re.compile(r"<!-- not run: (.+?) -->")
FENCE = re.compile(r"^```(\w*)\s*$")


@dataclass(frozen=True)
class Block:
    path: Path
    line: int  # of the opening fence, from 1
    lang: str
    text: str
    not_run: str | None  # the reason given above it, if any

    @property
    def id(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def blocks(paths: list[Path] = DOCS) -> list[Block]:
    found = []
    for path in paths:
        lines = path.read_text().splitlines()
        i = 0
        while i < len(lines):
            opening = FENCE.match(lines[i])
            if not opening:
                i += 1
                continue
            end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
            before = [text for text in lines[:i] if text.strip()]
            marker = NOT_RUN.search(before[-1]) if before else None
            found.append(Block(path, i + 1, opening.group(1), "\n".join(lines[i + 1:end]),
                               marker.group(1) if marker else None))
            i = end + 1
    return found


def _of(*langs: str) -> list[Block]:
    return [b for b in blocks() if b.lang in langs]


def test_the_docs_have_blocks_of_each_kind():
    kinds = {b.lang for b in blocks()}
    assert {"python", "yaml", "bash"} <= kinds


def test_every_shell_block_runs_or_says_why_not():
    """None is executed (minutes to hours each): each names its reason."""
    missing = [b.id for b in _of("bash", "sh") if not b.not_run]
    assert not missing, f"shell blocks without '<!-- not run: REASON -->': {missing}"


def _make_targets() -> set[str]:
    text = (ROOT / "Makefile").read_text()
    return set(re.findall(r"^([A-Za-z0-9_-]+):", text, flags=re.MULTILINE))


def _command_lines(block: Block) -> list[list[str]]:
    out = []
    for raw in block.text.replace("\\\n", " ").splitlines():  # continuation lines joined
        line = raw.split(" #")[0].strip() if not raw.strip().startswith("#") else ""
        if line:
            out.append(shlex.split(line))
    return out


@pytest.mark.parametrize("block", _of("bash", "sh"), ids=lambda b: b.id)
def test_shell_lines_name_real_targets_commands_and_files(block):
    from shapegrowth.commands.cli import build_parser

    targets = _make_targets()
    copied = set()  # files a `cp` earlier in the block makes
    for words in _command_lines(block):
        if words[0] == "cp":
            copied.add(words[-1])
            continue
        if words[0] == "mpirun":  # mpirun -n N [--oversubscribe] PROGRAM ...
            words = words[3:] if words[1] == "-n" else words[1:]
            words = [w for w in words if w != "--oversubscribe"]
        program, args = words[0], words[1:]
        if program in ("make",):
            for target in (a for a in args if "=" not in a):
                assert target in targets, f"{block.id}: no make target {target!r}"
        elif program.endswith("bin/shapegrowth"):
            if any(a.isupper() for a in args):
                continue  # a synopsis (CONFIG, DIR), not a command line
            build_parser().parse_args(args)  # an unknown option exits (status 2)
            for a in args:
                if a.endswith((".yaml", ".yml")):
                    assert (ROOT / a).is_file() or a in copied, f"{block.id}: {a} does not exist"
        elif program.endswith("bin/python") and args and args[0].endswith(".py"):
            assert (ROOT / args[0]).is_file(), f"{block.id}: {args[0]} does not exist"


@pytest.mark.parametrize("block", _of("yaml"), ids=lambda b: b.id)
def test_yaml_blocks_parse_and_whole_configs_validate(block):
    from shapegrowth.config import from_dict

    data = yaml.safe_load(block.text)
    assert isinstance(data, dict) and data, block.id
    if "name" in data and "geometry" in data:  # a whole config, not a fragment
        from_dict(data)


@pytest.mark.slow
@pytest.mark.parametrize("block", _of("python"), ids=lambda b: b.id)
def test_python_blocks_run_as_written(block, tmp_path):
    if block.not_run:
        pytest.skip(block.not_run)
    script = tmp_path / "block.py"
    script.write_text(block.text + "\n")
    done = subprocess.run([sys.executable, str(script)], cwd=ROOT, capture_output=True,
                          text=True, timeout=900, env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, f"{block.id}\n{done.stderr[-3000:]}"


def _script(name: str):
    """scripts/NAME.py as a module (the generators of the pages the tests hold current)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_layer_map_is_generated_from_the_package_and_names_every_module():
    """docs/LAYERS.md is scripts/layers_reference.py's text (regenerate it after adding a
    module or changing a docstring's first sentence); it names every module once, and the
    paper's equations name modules that exist."""
    script = _script("layers_reference")
    text = (ROOT / "docs" / "LAYERS.md").read_text()
    assert text == script.layers_markdown(), "docs/LAYERS.md is stale: run " \
        "scripts/layers_reference.py"
    package = ROOT / "shapegrowth"
    modules = {str(p.relative_to(package)) for p in package.rglob("*.py")
               if p.name != "__init__.py"}
    named = re.findall(r"^\| `([\w/]+\.py)` \|", text, flags=re.MULTILINE)
    assert sorted(named) == sorted(modules)
    assert set(script.PAPER) <= modules
    assert {layer for layer, _ in script.LAYERS} == {
        str(p.relative_to(package)) for p in package.iterdir()
        if p.is_dir() and (p / "__init__.py").is_file()} | {""}


CONFIGS_DIR = ROOT / "configs"


def _comment_and_key_lines(path: Path) -> tuple[int, int, int]:
    """(comment lines, key lines, comment lines before the first key) of a YAML file."""
    comments = keys = opening = 0
    for line in path.read_text().splitlines():
        if not line.strip():
            continue
        if line.lstrip().startswith("#"):
            comments += 1
            opening += keys == 0
        else:
            keys += 1
    return comments, keys, opening


@pytest.mark.parametrize("config", sorted(CONFIGS_DIR.rglob("*.yaml")),
                         ids=lambda p: str(p.relative_to(CONFIGS_DIR)))
def test_a_config_to_copy_opens_with_six_comment_lines_at_most_and_is_mostly_keys(config):
    """A user copies a shipped config: it opens with at most 6 comment lines (the scene, the
    reading, where its numbers are) and has no more comment lines than key lines; the
    derivations and measurements live in docs/SCENES.md and the pages it links."""
    comments, keys, opening = _comment_and_key_lines(config)
    assert opening <= 6, f"{config.name}: opens with {opening} comment lines"
    assert comments <= keys, f"{config.name}: {comments} comment lines for {keys} key lines"


_CITED_MD = re.compile(r"[A-Za-z0-9_./-]*[A-Za-z0-9_-]+\.md\b")


def _tracked_text_files() -> list[Path]:
    """The repository's own text files: its folders of source, docs and configs and its
    top-level files (no git needed: the Debian 13 leg copies the checkout without it)."""
    suffixes = {".py", ".md", ".yaml", ".yml", ".sh", ".toml", ".txt"}
    folders = ("shapegrowth", "tests", "scripts", "benchmarks", "notebooks", "docs", "configs",
               ".ci")
    files = [p for folder in folders for p in sorted((ROOT / folder).rglob("*"))
             if p.is_file() and (p.suffix in suffixes or p.parent.name == ".ci")
             and "img" not in p.relative_to(ROOT).parts]
    return files + [ROOT / name for name in ("README.md", "Makefile", "pyproject.toml")
                    if (ROOT / name).is_file()]


def test_every_cited_markdown_file_is_in_the_repository():
    """A clone holds every page its files cite: a name ending in .md resolves beside the
    citing file, at the repository's root or in docs/ (run outputs under results/ aside)."""
    missing = []
    for path in _tracked_text_files():
        text = path.read_text(errors="replace")
        for match in _CITED_MD.finditer(text):
            name = match.group()
            if name.startswith(("results/", "./results/")) or "/results/" in name:
                continue
            if path.suffix == ".py" and match.start() and text[match.start() - 1] in "\"'":
                continue  # a file a script writes or reads, not a page cited
            name = name.lstrip("./") if name.startswith("./") else name
            places = (path.parent / name, ROOT / name, ROOT / "docs" / name)
            if not any(p.is_file() for p in places):
                missing.append(f"{path.relative_to(ROOT)}: {name}")
    assert not missing, f"cited but not in the repository: {missing}"


def test_the_readme_s_first_run_is_the_shipped_example():
    """README's own-body block is configs/examples/strip_quarter.yaml, key for key."""
    text = (ROOT / "README.md").read_text()
    block = text.split("```yaml\n", 1)[1].split("```", 1)[0]
    shipped = yaml.safe_load((ROOT / "configs" / "examples" / "strip_quarter.yaml").read_text())
    assert yaml.safe_load(block) == shipped


def _paragraphs(text: str) -> list[str]:
    """Prose paragraphs of a Markdown text: fenced blocks, tables and headings left out."""
    out, current, fenced = [], [], False
    for line in text.splitlines():
        if line.startswith("```"):
            fenced = not fenced
            continue
        if fenced or line.startswith(("|", "#", "<!--", "![")):
            line = ""
        if line.strip():
            current.append(line)
        elif current:
            out.append(" ".join(current))
            current = []
    if current:
        out.append(" ".join(current))
    return out


def test_the_readme_is_short_and_its_paragraphs_too():
    """A user's README: at most 200 lines, no paragraph over 120 words, and no shape error
    of its own (numbers live in docs/RESULTS.md, which it links)."""
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 200
    long = [p[:60] for p in _paragraphs(text) if len(p.split()) > 120]
    assert not long, long
    assert not re.findall(r"\d+(?:\.\d+)? %", text), "README quotes a percentage"
    assert "docs/RESULTS.md" in text


# The pages that explain (Diataxis's "explanation"): each states today's answer with the
# measurement behind it; the measurements as they were made live in docs/history/
EXPLANATION = ("MODELS.md", "VERIFICATION.md", "STABILITY.md", "PERFORMANCE.md",
               "REPRODUCIBILITY.md", "SCENES.md", "SHELLS.md")
_HISTORY = "history/"


@pytest.mark.parametrize("page", EXPLANATION)
def test_an_explanation_page_is_at_most_about_300_lines_and_says_today_s_answer(page):
    text = (ROOT / "docs" / page).read_text()
    assert len(text.splitlines()) <= 300, f"{page}: {len(text.splitlines())} lines"
    assert not re.search(r"\b(?:the )?(?:\w+teenth|\w+tieth|\w+th) reproduction against",
                         text), f"{page} compares reproductions by their order"


def test_nothing_outside_the_history_depends_on_it():
    """docs/history/ is the lab notebook: only the docs' maps link it (the folder's index),
    and no code, config, script, test or other page cites a page in it."""
    maps = {ROOT / "README.md", ROOT / "docs" / "INSTALL.md"}
    citing = []
    for path in _tracked_text_files():
        if _HISTORY in str(path.relative_to(ROOT)) or path == Path(__file__):
            continue
        for match in re.finditer(r"history/[A-Za-z0-9_./-]*", path.read_text(errors="replace")):
            if path in maps and match.group() in ("history/", "history/README.md"):
                continue
            citing.append(f"{path.relative_to(ROOT)}: {match.group()}")
    assert not citing, citing


_PAGES = "|".join(p.stem for p in (ROOT / "docs").glob("*.md"))
# a page named with the section it cites, as docs/MODELS.md, "Reduced models" (or linked)
_CITED_SECTION = re.compile(r"\b(" + _PAGES + r")\.md(?:\]\([^)]*\))?,\s+[\\]?([\"'])(.+?)(?:[\\]?\2|$)",
                            re.MULTILINE)


def _headings(page: str) -> list[str]:
    text = (ROOT / "docs" / f"{page}.md").read_text()
    return [h.strip().strip("#").strip().strip("`") for h in text.splitlines()
            if h.startswith("#")]


def test_every_cited_section_is_a_heading_of_its_page():
    """A citation of a section ("docs/PERFORMANCE.md, 'Continued'") names a heading of that
    page (the heading may go on where a line or a string ends), so moving a section breaks a
    test, not a reader's search."""
    missing = []
    for path in _tracked_text_files():
        if _HISTORY in str(path.relative_to(ROOT)):
            continue
        text = path.read_text(errors="replace")
        for match in _CITED_SECTION.finditer(text):
            page, cited = match.group(1), match.group(3).rstrip(" \"'\\")
            cited = cited.split("(")[0].strip() if cited.endswith("(") else cited
            if not cited or not (cited[0].isupper() or cited[0] in "`"):
                continue  # a sentence, not a section's name
            heads = _headings(page)
            if not any(h.startswith(cited) or cited.startswith(h) for h in heads):
                missing.append(f"{path.relative_to(ROOT)}: {page}.md, {cited!r}")
    assert not missing, missing


def test_summary_json_s_keys_are_documented_from_the_types_that_write_them():
    """docs/OUTPUTS.md's table of summary.json's keys is scripts/summary_reference.py's text,
    generated from RunSummary and the records it holds: a field added without its meaning
    fails here (KeyError), and a stale page too."""
    module = _script("summary_reference")
    keys = [k for k, _ in module.keys()]
    assert len(keys) == len(set(keys))
    assert {"verified.relative", "lifted.relative", "hausdorff_final", "stability.stable",
            "linear_solver.preset", "dofs.state"} <= set(keys)
    assert set(module.MEANING) == set(keys), "MEANING names a key no type writes"
    assert (ROOT / "docs" / "OUTPUTS.md").read_text() == module.page(), \
        "docs/OUTPUTS.md is stale: run scripts/summary_reference.py"


def test_the_command_line_reference_is_generated_from_its_parser():
    """docs/CLI.md is scripts/cli_reference.py's text: every command with every argument and
    option the parser takes, and its help."""
    module = _script("cli_reference")
    text = module.markdown()
    assert "## `shapegrowth verify`" in text and "`--continued`" in text
    assert (ROOT / "docs" / "CLI.md").read_text() == text, \
        "docs/CLI.md is stale: run scripts/cli_reference.py"
