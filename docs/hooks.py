"""The documentation site's front page is the repository's README (mkdocs.yml names this file as a hook): its links
into docs/ are made relative to the site (the README links to no other file of the repository)."""

from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]


def on_files(files, config):
    text = (ROOT / "README.md").read_text().replace("](docs/", "](")
    files.append(File.generated(config, "index.md", content=text))
    return files
