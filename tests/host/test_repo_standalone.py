"""The repository stands alone: no tracked file refers to a place outside it.

A fresh clone has only what git tracks. A reference to a folder beside the repository,
to an absolute path of one machine, or to a document that is not in the repository leaves a
newcomer with nothing to read; the system description is docs/system.md.
"""

from __future__ import annotations

import re
import subprocess

import pytest

# Built from pieces so that this file does not match its own patterns.
OUTSIDE = [
    (re.compile(r"\.\./+shared\b"), "a sibling folder outside the repository"),
    (re.compile("/" + r"work/"), "an absolute path of one machine"),
    (re.compile("/" + r"(home|root)/\w"), "an absolute path of one machine"),
    (re.compile(r"\bREFERENCE(\.md| §)"), "a document kept outside the repository (use docs/system.md)"),
    (re.compile(r"TOOLCHAIN" + r"-NOTES"), "a document kept outside the repository"),
]
DOC_REF = re.compile(r"\bdocs/([A-Za-z0-9_.-]+\.md)\b")


def tracked_text_files(repo) -> dict[str, str]:
    try:
        out = subprocess.run(
            ["git", "-C", str(repo), "ls-files", "-z"], capture_output=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    files = {}
    for name in out.decode().split("\0"):
        path = repo / name
        if not name or not path.is_file():
            continue
        data = path.read_bytes()
        if b"\0" in data:
            continue  # binary
        files[name] = data.decode("utf-8", errors="replace")
    return files


def test_no_tracked_file_refers_outside_the_repository(repo_root):
    files = tracked_text_files(repo_root)
    assert len(files) > 50, "git ls-files found too few files"
    bad = []
    for name, text in files.items():
        for lineno, line in enumerate(text.splitlines(), 1):
            for pattern, why in OUTSIDE:
                if pattern.search(line):
                    bad.append(f"{name}:{lineno}: {why}: {line.strip()[:100]}")
    assert not bad, "references outside the repository:\n" + "\n".join(bad)


def test_every_cited_doc_exists(repo_root):
    files = tracked_text_files(repo_root)
    missing = []
    for name, text in files.items():
        for m in DOC_REF.finditer(text):
            if not (repo_root / "docs" / m.group(1)).is_file():
                missing.append(f"{name}: docs/{m.group(1)}")
    assert not missing, "cited documents that do not exist:\n" + "\n".join(sorted(set(missing)))


def test_system_description_names_the_paper(repo_root):
    text = (repo_root / "docs" / "system.md").read_text()
    assert "10.3390/s17030655" in text
    for section in range(1, 9):
        assert re.search(rf"^## {section}\. ", text, re.M), f"docs/system.md lacks section {section}"
