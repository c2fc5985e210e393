"""The documentation: the site builds with every link and anchor found, a section named beside a page's path is a
heading of that page, and every number of the README is one of the results."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RESULTS = [ROOT / "docs" / "RESULTS.md", *sorted((ROOT / "docs" / "results").glob("*.md"))]
# where the code, the configs and the docs name a section of a page: docs/results/speed.md, "The levers of ..."
# (a comment may wrap the title: its line breaks and comment marks are read as spaces)
SECTION = re.compile(r"(docs/[\w/-]+\.md)\)?,? \(?\"([^\"]+)\"")
VERSIONED = re.compile(r"(Python|CPython|donkeycar|torch|TensorFlow|OpenCV|Engine\.IO|socketio|engineio)\s+$")


def test_the_site_builds_with_every_link_and_anchor_found(tmp_path):
    """`make docs` builds with --strict: a link to a page or an anchor that is not there fails the build."""
    pytest.importorskip("mkdocs")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "WARNING" not in done.stderr
    front = (tmp_path / "site" / "index.html").read_text()
    assert "steerlab" in front and 'href="RESULTS/"' in front  # the README, its links into docs/ made the site's


def _sources():
    for folder in ("src", "configs", "tests", "studies", "benchmarks", "docs", ".ci"):
        yield from (p for p in (ROOT / folder).rglob("*") if p.suffix in (".py", ".yaml", ".md", ".sh"))
    yield from (ROOT / "README.md", ROOT / "Makefile", ROOT / "pyproject.toml")


def section_references(text: str) -> list[tuple[str, str]]:
    """The (page, title) pairs `text` names, its comments' line breaks read as spaces."""
    flat = re.sub(r"\s*\n\s*(?:#\s*)?", " ", text)
    return SECTION.findall(flat)


def headings(page: Path) -> list[str]:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
    return [h.strip() for h in re.findall(r"^#{1,6} (.+)$", text, flags=re.M)]


def test_a_section_named_beside_a_page_is_a_heading_of_that_page():
    found = 0
    for path in _sources():
        if path.name == "test_docs.py":
            continue
        for page, title in section_references(path.read_text(errors="replace")):
            found += 1
            assert (ROOT / page).is_file(), f"{path.relative_to(ROOT)} names {page}, which does not exist"
            assert any(re.match(re.escape(title) + r"(\W|$)", h) for h in headings(ROOT / page)), (
                f"{path.relative_to(ROOT)} names the section \"{title}\" of {page}, which has no such heading")
    assert found > 10


def test_section_references_are_read_across_wrapped_comments():
    text = '# measured (docs/results/speed.md, "The levers of a\n# training step"); docs/RESULTS.md ("Machines")'
    assert section_references(text) == [("docs/results/speed.md", "The levers of a training step"),
                                         ("docs/RESULTS.md", "Machines")]


def _prose(text: str) -> str:
    return re.sub(r"`[^`\n]*`", "", re.sub(r"```.*?```", "", text, flags=re.S))


UNIT = r"(?:%|x|ms|s|min|h|km|m|MB|GB|KB|rad|deg|frames/s|m/s|records/s)"
QUANTITY = re.compile(rf"(?<![\w.,])(x?)(\d+(?:,\d{{3}})*(?:\.\d+)?)(?!\.?\d)( ?{UNIT}(?![\w/]))?")


def quantities(text: str, integers: bool = False) -> set[str]:
    """The measured numbers of a Markdown text's prose (not its code): each with a decimal point, a unit or a
    leading x, written without thousands commas and spaces ('1051frames/s', 'x1.39', '0.1500'), and with
    `integers` every bare whole number of two digits or more too (a count: '110'); version numbers (after Python,
    torch, donkeycar, ...) are not measurements."""
    text = _prose(text)
    out = set()
    for m in QUANTITY.finditer(text):
        x, number, unit = m.groups()
        if VERSIONED.search(text[max(0, m.start() - 12): m.start()]):
            continue
        number = number.replace(",", "")
        if x or unit or "." in number or (integers and len(number) > 1):
            out.add(x + number + (unit or "").strip())
    return out


def test_quantities_are_read_as_written():
    text = "1,051 frames/s and x1.39, 0.1500 rad; `3.5 s` in code; donkeycar 5.2 on Python 3.11;\n16 tubs, 4.6.1"
    assert quantities(text) == {"1051frames/s", "x1.39", "0.1500rad"}
    assert quantities(text, integers=True) == {"1051frames/s", "x1.39", "0.1500rad", "16"}


def claims(text: str) -> list[tuple[set[str], list[Path]]]:
    """Each paragraph of a Markdown text with numbers in it: its numbers (counts included) and the results pages it
    links (docs/RESULTS.md and every page when it links none)."""
    out = []
    for paragraph in re.split(r"\n\s*\n", text):
        numbers = quantities(paragraph, integers=True)
        if numbers:
            links = sorted({ROOT / link for link in re.findall(r"\]\((docs/[^)#\s]+\.md)", paragraph)})
            out.append((numbers, [p for p in links if p in RESULTS] or RESULTS))
    return out


def test_every_number_of_the_readme_is_measured_on_the_page_its_paragraph_links():
    """A number the README claims (a time, a ratio, an error, a share, a count) is measured, written the same way,
    on a results page its paragraph links (docs/RESULTS.md or any page where the paragraph links none)."""
    missing = []
    for numbers, pages in claims((ROOT / "README.md").read_text()):
        found = set().union(*(quantities(p.read_text(), integers=True) for p in pages))
        missing += [(n, [p.name for p in pages]) for n in sorted(numbers - found)]
    assert not missing, f"README numbers not on the pages their paragraphs link: {missing}"


def test_a_readme_number_on_another_page_than_its_paragraph_links_is_missing():
    page = next(p for p in RESULTS if p.name == "install.md")
    text = "Raced: 58.6 % clean ([install](docs/results/install.md)).\n\nElsewhere: 58.6 % again."
    (numbers, pages), (_, everywhere) = claims(text)
    assert numbers == {"58.6%"} and pages == [page] and everywhere == RESULTS


def _doc_commands():
    """Every `steerlab ...` line of the README's and the docs' bash blocks (continuations joined; a comment, a pipe
    and what follows `&&` cut off), with a shell variable read as 1; lines that elide arguments (`...`) are not
    commands to run."""
    import re

    found = []
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for block in re.findall(r"```(?:bash|sh)\n(.*?)```", page.read_text(), re.S):
            for line in block.replace("\\\n", " ").splitlines():
                line = re.split(r"\s+#", line.strip())[0]
                line = re.split(r"\s*(?:&&|\||;|>)\s*", line)[0]
                if line.startswith("steerlab ") and "..." not in line:
                    found.append((page.relative_to(ROOT).as_posix(), re.sub(r"\$\{?\w+\}?", "1", line)))
    return found


def test_every_command_the_docs_show_is_one_the_cli_takes():
    """A command the README or a page shows parses as written (its subcommand, flags and arguments): a page that
    shows `steerlab export X Y` where the command takes `--out Y` is a user's first error."""
    import contextlib
    import io
    import shlex

    from steerlab.cli import build_parser

    commands, refused = _doc_commands(), []
    assert len(commands) > 100
    for page, line in commands:
        err = io.StringIO()
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                build_parser().parse_args(shlex.split(line)[1:])
        except SystemExit as e:
            if e.code:
                refused.append(f"{page}: {line}: {err.getvalue().strip()}")
    assert not refused, "\n".join(refused)
