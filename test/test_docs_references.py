"""References into the documentation stay valid: every page and section named in the repository, and every
relative link of the README and docs/.

A **reference** is a path ``docs/<path>.md`` in a ``.py``, ``.md``, ``.yaml`` or ``.sh`` file of the repository
(hidden folders such as .git and .venv, colcon's build/, install/ and log/, ``__pycache__`` and ``*.egg-info``
left out). The page must exist. If the path (or a markdown link whose text it is) is followed, after an optional
``,`` or ``:``, white space or a ``(``, by double-quoted names joined by ``,``, ``and`` or ``or``, each name is a
section of that page, e.g.::

    docs/studies/navigation.md, "A skew learned backwards"
    docs/studies/simulation.md "Model study"
    docs/navigation.md ("Not reached")
    docs/studies/simulation.md, "Which way a held spin rolls" and "Supply bundle"
    [docs/studies/navigation.md](docs/studies/navigation.md) "Where the time goes over DDS"

A name matches a section when it is the start of one of the page's headings (``#`` to ``######``, outside fenced
code) or of a bold lead: the bold text that opens a paragraph or a list item (``**Lead** ...`` or
``- **Lead** ...``, which may wrap over lines). The match is case-sensitive, on the text with backticks and
asterisks dropped and white space collapsed, so ``"A held spin"`` names the heading ``A held spin:
`config/sim_held_spin.yaml` (stop 50)``. A comment or docstring that wraps is read as one text: each line's
indentation and leading ``#`` or ``#:`` are dropped and the lines joined by a space, so a name may wrap too.

A **relative link** (``](x.md)``, ``](../y.md#anchor)``, any target without a scheme) of README.md or of a page
under docs/ must point to an existing file; the anchor is not checked.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SUFFIXES = (".py", ".md", ".yaml", ".sh")
SKIPPED_FOLDERS = frozenset({"build", "install", "log", "__pycache__"})

#: ``docs/<path>.md`` (or the text of a link ``[docs/<path>.md](...)``) and the quoted names after it (one or more,
#: joined by ``,``, ``and`` or ``or``).
REFERENCE = re.compile(
    r'(?<![\w/.])(docs/[\w/.-]+?\.md)(?:\]\([^)\s]*\))?'
    r'(?:(?:[,:]?\s+|\s*\()\(?((?:"[^"\n]{1,200}")(?:\s*(?:,|and|or|, and|, or)\s*"[^"\n]{1,200}")*))?')
QUOTED = re.compile(r'"([^"\n]+)"')
HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
BOLD_LEAD = re.compile(r"^\s*(?:[-*+]\s+)?\*\*")
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _source_files(root: Path):
    for folder, subfolders, files in os.walk(root):
        subfolders[:] = sorted(d for d in subfolders if not d.startswith(".") and d not in SKIPPED_FOLDERS
                               and not d.endswith(".egg-info"))
        for name in sorted(files):
            if name.endswith(SUFFIXES):
                yield Path(folder) / name


def _flat(text: str) -> str:
    """The text as one line: each line's indentation and comment marker dropped, lines joined by a space."""
    return " ".join(re.sub(r"^\s*(?:#:?(?=\s|$))?\s*", "", line) for line in text.splitlines())


def _normal(name: str) -> str:
    name = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", name)  # a link: its text
    return " ".join(name.replace("`", "").replace("*", "").split())


def section_names(page_text: str) -> list[str]:
    """The page's headings and bold leads (see the module docstring), normalised."""
    lines, names, fenced = page_text.splitlines(), [], False
    for i, line in enumerate(lines):
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
            continue
        if fenced:
            continue
        heading = HEADING.match(line)
        if heading:
            names.append(_normal(heading.group(2)))
            continue
        lead = BOLD_LEAD.match(line)
        if lead:
            text = " ".join([line[lead.end():], *(part.strip() for part in lines[i + 1:i + 6])])
            end = text.find("**")
            if end > 0:
                names.append(_normal(text[:end]))
    return names


def references(text: str) -> list[tuple[str, list[str]]]:
    """Each ``docs/<path>.md`` of the text with the section names quoted after it."""
    found = []
    for match in REFERENCE.finditer(_flat(text)):
        names = QUOTED.findall(match.group(2) or "")
        found.append((match.group(1).rstrip("."), names))
    return found


def broken_references(root: Path) -> list[str]:
    """One line per reference whose page is missing or has no section starting with the name."""
    broken, pages = [], {}
    for path in _source_files(root):
        for page, names in references(path.read_text(errors="ignore")):
            where = f"{path.relative_to(root)}: {page}"
            target = root / page
            if not target.is_file():
                broken.append(f"{where}: no such page")
                continue
            if page not in pages:
                pages[page] = section_names(target.read_text())
            for name in names:
                if not any(section.startswith(_normal(name)) for section in pages[page]):
                    broken.append(f'{where}: no heading or bold lead starts with "{name}"')
    return sorted(set(broken))


def broken_links(root: Path) -> list[str]:
    broken = []
    for page in [root / "README.md", *sorted((root / "docs").rglob("*.md"))]:
        for target in LINK.findall(page.read_text()):
            path = target.split("#")[0]
            if not path or re.match(r"[a-z][a-z0-9+.-]*:", path):
                continue
            if not (page.parent / path).exists():
                broken.append(f"{page.relative_to(root)} -> {target}")
    return broken


# ------------------------------------------------------------------------------------------
# The repository
# ------------------------------------------------------------------------------------------
def test_every_page_and_section_named_in_the_repository_exists():
    assert broken_references(ROOT) == []


def test_every_relative_link_of_the_readme_and_docs_points_to_a_file():
    assert broken_links(ROOT) == []


def test_the_repository_names_sections_of_both_guides_and_both_study_logs():
    # The scan itself must see the references, or the two tests above pass on nothing.
    pages = {page for path in _source_files(ROOT) for page, names in references(path.read_text(errors="ignore"))
             if names}
    assert {"docs/navigation.md", "docs/simulation.md", "docs/studies/navigation.md",
            "docs/studies/simulation.md"} <= pages


# ------------------------------------------------------------------------------------------
# The rule, on made-up pages (the paths are built so that the scan above does not read them)
# ------------------------------------------------------------------------------------------
PAGE, GONE = "docs" + "/guide.md", "docs" + "/gone.md"

GUIDE = """# The guide

## A held spin: `config/held.yaml` (stop 50)

**Not reached:**

- **The time target** is 2 x.

**Keeping the robot
in view** (2026-11-24): the bold lead wraps.

```bash
# not a heading: a comment in a code block
```
"""


def _repo(tmp_path: Path, source: str) -> Path:
    (tmp_path / "docs").mkdir()
    (tmp_path / PAGE).write_text(GUIDE)
    (tmp_path / "code.py").write_text(source)
    return tmp_path


def test_names_match_the_start_of_a_heading_or_a_bold_lead_without_markup(tmp_path):
    source = (f'#: held ({PAGE}, "A held spin: config/held.yaml"); limits: {PAGE} ("Not reached")\n'
              f'"""Also {PAGE}, "The time target" and "Keeping the robot in view"."""\n')
    assert broken_references(_repo(tmp_path, source)) == []


def test_a_name_wrapped_over_comment_lines_is_read_whole(tmp_path):
    source = f'x = 1  # see {PAGE}, "Keeping the\n#   robot in view" for the guard\n'
    assert references(source) == [(PAGE, ["Keeping the robot in view"])]
    assert broken_references(_repo(tmp_path, source)) == []


def test_a_missing_section_a_wrong_case_a_code_comment_and_a_missing_page_are_reported(tmp_path):
    source = (f'# {PAGE}, "A skew learned backwards"\n'
              f'# {PAGE}, "a held spin"\n'
              f'# {PAGE}, "not a heading"\n'
              f"# {GONE} is gone\n")
    assert broken_references(_repo(tmp_path, source)) == [
        f"code.py: {GONE}: no such page",
        f'code.py: {PAGE}: no heading or bold lead starts with "A skew learned backwards"',
        f'code.py: {PAGE}: no heading or bold lead starts with "a held spin"',
        f'code.py: {PAGE}: no heading or bold lead starts with "not a heading"',
    ]


def test_a_path_without_a_quoted_name_and_a_string_that_ends_at_the_path_name_no_section(tmp_path):
    assert references(f'help="waits for it; {PAGE}")\nprint("other")\n') == [(PAGE, [])]
    assert references(f"# {PAGE}: 0 of 30 goals, {PAGE}.\n") == [(PAGE, []), (PAGE, [])]


def test_a_relative_link_to_a_missing_file_is_reported(tmp_path):
    (tmp_path / "docs" / "studies").mkdir(parents=True)
    (tmp_path / "README.md").write_text(f"[guide]({PAGE}), [web](https://example.org/x.md)\n")
    (tmp_path / PAGE).write_text("[log](studies/log.md#a-section), [back](../README.md)\n")
    (tmp_path / "docs" / "studies" / "log.md").write_text("[guide](../guide.md), [old](../old.md#x)\n")
    assert broken_links(tmp_path) == [str(Path("docs", "studies", "log.md")) + " -> ../old.md#x"]
