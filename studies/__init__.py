"""The studies: experiments whose results docs/RESULTS.md reports, each a module run from the repository root as
`python -m studies.NAME` (its docstring says what it measures and how to run it). What they share is in
`studies.common`; a study imports steerlab and `studies.common` (and its own private modules, `studies._NAME`),
never another study nor the tests."""
