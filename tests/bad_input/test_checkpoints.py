"""Checkpoints and exports: a damaged one (a byte flipped, cut off, its statistics changed) or one holding
code is refused naming the file, every form is sealed and checked, and rule 5: only the checkpoints of earlier
versions are taken as earlier versions."""

import os
import shutil
from pathlib import Path

import pytest

from steerlab.errors import SteerlabError
from tests.bad_input.builders import _damaged, _train, refused_in_one_line, trained
from tests.inputs import flip_bytes, made, sim_log


def _flipped(tmp_path, stack):
    best = flip_bytes(trained(tmp_path))
    return ["evaluate", str(best), "--data", str(tmp_path / "sim"), "--out", str(tmp_path / "eval")]


def _flipped_before_seals(tmp_path, stack):
    """A checkpoint of steerlab 0.1.0 (no seal; the sha256 of its weights inside) with damaged weights."""
    old = tmp_path / "old.pt"
    shutil.copy(Path(__file__).parents[1] / "fixtures" / "run-0.1.0" / "best.pt", old)
    return ["evaluate", str(flip_bytes(old)), "--data", str(sim_log(tmp_path / "sim")), "--out", str(tmp_path / "eval")]


class _Code:
    """A pickled object that runs a command when unpickled without weights_only."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


def _code_in_checkpoint(tmp_path, stack):
    import torch

    path = tmp_path / "evil.pt"
    torch.save({"format": "steerlab-checkpoint-1", "state_dict": {}, "hook": _Code(tmp_path / "ran")}, path)
    sim_log(tmp_path / "sim")
    return ["evaluate", str(path), "--data", str(tmp_path / "sim"), "--out", str(tmp_path / "eval")]


def _truncated(path):
    """A checkpoint cut off after its first kilobyte (a copy that did not finish)."""
    path.write_bytes(path.read_bytes()[:1000])
    return path


def _flipped_onnx(tmp_path, stack):
    from steerlab.export import export_onnx

    onnx = flip_bytes(export_onnx(made(tmp_path), tmp_path / "m.onnx"))
    return ["evaluate", str(onnx), "--data", str(sim_log(tmp_path / "sim")), "--out", str(tmp_path / "eval")]


def _exported(tmp_path):
    from steerlab.export import export_onnx

    return export_onnx(made(tmp_path), tmp_path / "m.onnx")


def _onnx_metadata(change):
    """An exported model whose metadata_props `change(props)` edits (a dict key -> value), then evaluated."""
    def command(tmp_path, stack):
        import onnx

        from steerlab.export import export_onnx

        path = export_onnx(made(tmp_path), tmp_path / "m.onnx")
        proto = onnx.load(path)
        props = {e.key: e.value for e in proto.metadata_props}
        change(props)
        del proto.metadata_props[:]
        for key, value in props.items():
            proto.metadata_props.add(key=key, value=value)
        onnx.save(proto, path)
        return ["evaluate", str(path), "--data", str(sim_log(tmp_path / "sim")), "--out", str(tmp_path / "eval")]
    return command


def _stats_changed(tmp_path, stack):
    """One stored value changed in a sealed checkpoint (the first channel's mean, as a flipped bit would): its bytes
    no longer match the sha256 sealed with them."""
    import io

    import torch

    from steerlab.checkpoint import SEAL

    best = trained(tmp_path)
    seal = best.read_bytes()[-2 - len(SEAL) - 64:]  # the zip comment: its length, the seal and the digest
    ckpt = torch.load(best, weights_only=True)
    ckpt["stats"]["mean"][0] = 4.52
    buffer = io.BytesIO()
    torch.save(ckpt, buffer)
    best.write_bytes(buffer.getvalue()[:-2] + seal)
    return ["evaluate", str(best), "--data", str(tmp_path / "sim"), "--out", str(tmp_path / "eval")]


def _stats_changed_before_seals(tmp_path, stack):
    """The same in a checkpoint as steerlab wrote it before seals: no seal, the sha256 of its contents inside."""
    import torch

    from steerlab.checkpoint import content_hash

    best = trained(tmp_path)
    ckpt = torch.load(best, weights_only=True)
    ckpt["content_sha256"] = content_hash(ckpt)
    ckpt["stats"]["mean"][0] = 4.52
    torch.save(ckpt, best)
    return ["evaluate", str(best), "--data", str(tmp_path / "sim"), "--out", str(tmp_path / "eval")]


def _teacher(make):
    """train.teacher naming what `make(tmp_path)` writes."""
    return lambda t, s: _train(f"train.teacher={make(t)}")(t, s)


def _pickled(tmp_path):
    import pickle

    path = tmp_path / "plain.pt"
    path.write_bytes(pickle.dumps({"weights": [1.0, 2.0]}))
    return path


# each case: a function (tmp_path, stack) -> the command's arguments, and the message's substring (builders.py)
BAD_INPUTS = {
    # f) checkpoints: damaged, or holding code
    "checkpoint flipped bytes": (_flipped, "best.pt: the file's bytes do not match the sha256 stored with them"),
    "checkpoint of 0.1.0 flipped bytes": (_flipped_before_seals, "old.pt: the weights do not match the checkpoint's "
                                                                 "sha256: the file is damaged"),
    "checkpoint that is a text file": (lambda t, s: (t / "notes.pt").write_text("not a zip\n") and
                                       ["export", str(t / "notes.pt"), "--out", str(t / "m.onnx")],
                                       "notes.pt: not a readable checkpoint (not the zip file torch.save writes)"),
    "checkpoint with code": (_code_in_checkpoint, "evil.pt: the checkpoint holds objects other than tensors and "
                                                  "plain values (posix.system)"),
    "onnx flipped bytes": (_flipped_onnx, "m.onnx: the model does not match the sha256 in its metadata: the file "
                                          "is damaged"),
    "onnx metadata edited": (_onnx_metadata(lambda m: m.update(steerlab=m["steerlab"].replace('"sim"', '"ch2"'))),
                             "m.onnx: the model does not match the sha256 in its metadata"),
    "onnx without steerlab metadata": (_onnx_metadata(dict.clear),
                                       "m.onnx: no steerlab metadata in the model: not written by steerlab export"),
    "checkpoint with its statistics changed": (_stats_changed, "best.pt: the file's bytes do not match the sha256 "
                                                               "stored with them: the file is damaged"),
    "checkpoint before seals with its statistics changed": (
        _stats_changed_before_seals, "best.pt: the checkpoint's settings (statistics, preprocessing, convention, "
                                     "training state) do not match its sha256"),
    "ensemble with a truncated member": (lambda t, s: ["ensemble", str(made(t, name="a.pt")),
                                                       str(_truncated(made(t, name="b.pt"))), "--out", str(t / "e.pt")],
                                         "b.pt: not a readable checkpoint"),
    "ensemble of one": (lambda t, s: ["ensemble", str(made(t)), "--out", str(t / "e.pt")],
                        "an ensemble needs at least two checkpoints"),
    "train with a plain pickle as teacher": (_teacher(_pickled), "plain.pt: not a readable checkpoint (not the zip "
                                                                 "file torch.save writes)"),
    "train with an .onnx teacher": (_teacher(_exported), "m.onnx: train.teacher: an .onnx file cannot be a teacher"),
    "latency onnx file on torch": (lambda t, s: ["latency", str(_exported(t)), "--runtime", "torch"],
                                   "m.onnx runs on ONNX Runtime only: time it with steerlab latency --runtime "
                                   "onnx or both"),
}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_refused_in_one_line(case, tmp_path, capsys):
    refused_in_one_line(BAD_INPUTS[case], tmp_path, capsys)


def test_checkpoints_load_without_pickled_code_and_are_sealed(tmp_path):
    import hashlib

    import torch

    from steerlab.checkpoint import SEAL, load_checkpoint

    best = trained(tmp_path)
    raw = torch.load(best, weights_only=True)  # tensors and plain values only
    assert torch.load(tmp_path / "run" / "last.pt", weights_only=True)["epoch"] == 1
    data = best.read_bytes()  # the zip's comment: the seal, then the sha256 of every byte before the digest
    assert data[-64 - len(SEAL):-64] == SEAL and data[-64:] == hashlib.sha256(data[:-64]).hexdigest().encode()
    torch.save(raw, tmp_path / "plain.pt")  # written again by torch.save alone (no seal): changed by another tool
    with pytest.raises(SteerlabError, match="plain.pt: a checkpoint that steerlab sealed, without its seal: it was "
                                            "written again by another tool"):
        load_checkpoint(tmp_path / "plain.pt")
    torch.save({**raw, "format": "steerlab-checkpoint-1"}, tmp_path / "first.pt")  # as the first versions wrote it
    assert load_checkpoint(tmp_path / "first.pt")["model"] == "pilotnet"


def test_each_hash_of_a_checkpoint_is_checked_and_an_earlier_geometry_name_is_read(tmp_path):
    """The inner hashes of the versions before seals, each checked on its own (a changed weight, a changed
    statistic), a sealed file whose stored bytes changed while it still reads, a missing file named as a checkpoint,
    and the camera geometry's earlier name (`preset`) read as `geometry`."""
    import torch

    from steerlab.checkpoint import content_hash, load_checkpoint, save_payload, weights_hash

    raw = torch.load(trained(tmp_path), weights_only=True)
    raw = {k: v for k, v in raw.items() if k not in ("sha256", "content_sha256", "format")}  # save_payload sets it
    weights = {k: v.clone() for k, v in raw["state_dict"].items()}
    first = {**raw, "format": "steerlab-checkpoint-1", "sha256": weights_hash(weights)}
    for name, content in (("no-weights.pt", {"format": "steerlab-checkpoint-1"}), ("a-list.pt", [1, 2])):
        torch.save(content, tmp_path / name)
        with pytest.raises(SteerlabError, match=f"{name}: not a steerlab checkpoint"):
            load_checkpoint(tmp_path / name)
    (tmp_path / "m.onnx").write_bytes(b"an ONNX model")
    with pytest.raises(SteerlabError, match="m.onnx: an exported .onnx model, not a steerlab checkpoint"):
        load_checkpoint(tmp_path / "m.onnx")
    torch.save(first, tmp_path / "first.pt")
    assert load_checkpoint(tmp_path / "first.pt")["sha256"] == weights_hash(weights)  # intact: taken
    name = next(iter(weights))
    torch.save({**first, "state_dict": {**weights, name: weights[name] + 1}}, tmp_path / "weights.pt")
    with pytest.raises(SteerlabError, match="weights.pt: the weights do not match the checkpoint's sha256"):
        load_checkpoint(tmp_path / "weights.pt")
    earliest = {**{k: v for k, v in first.items() if k != "geometry"}, "preset": "ch2"}  # the geometry's earlier name
    torch.save(earliest, tmp_path / "earliest.pt")
    assert load_checkpoint(tmp_path / "earliest.pt")["geometry"] == "ch2" and "preset" not in load_checkpoint(
        tmp_path / "earliest.pt")

    def sealed_then_damaged(name, payload):  # the digest changed: the seal is broken, the zip still reads
        save_payload(tmp_path / name, payload)
        data = bytearray((tmp_path / name).read_bytes())
        data[-1] = ord("0") if data[-1] != ord("0") else ord("1")
        (tmp_path / name).write_bytes(bytes(data))
        return tmp_path / name

    whole = {**raw, "content_sha256": content_hash({**raw, "format": "steerlab-checkpoint-2"})}
    with pytest.raises(SteerlabError, match="sealed.pt: the file's bytes do not match the sha256 stored with them"):
        load_checkpoint(sealed_then_damaged("sealed.pt", whole))
    changed = {**whole, "stats": {**whole["stats"], "mean": [v + 1 for v in whole["stats"]["mean"]]}}
    with pytest.raises(SteerlabError, match="stats.pt: the checkpoint's settings .* do not match its sha256"):
        load_checkpoint(sealed_then_damaged("stats.pt", changed))
    with pytest.raises(SteerlabError, match="gone.pt: checkpoint not found"):
        load_checkpoint(tmp_path / "gone.pt")


def test_damaged_checkpoints_and_exports_are_refused_naming_the_file(tmp_path):
    from steerlab.checkpoint import load_checkpoint
    from steerlab.errors import SteerlabError
    from steerlab.export import export_onnx
    from steerlab.pilot import Pilot

    best = trained(tmp_path)
    onnx = export_onnx(best, tmp_path / "m.onnx")
    for good, load in ((best, load_checkpoint), (tmp_path / "run" / "last.pt", load_checkpoint), (onnx, Pilot)):
        data = good.read_bytes()
        for what, bad in _damaged(data):
            path = tmp_path / f"damaged{good.suffix}"
            path.write_bytes(bad)
            with pytest.raises(SteerlabError, match=f"^{path}: "):
                load(path)
            assert what  # every case refused
        good.write_bytes(data)
        load(good)  # the undamaged file still loads


def rule5_cases():
    """(how the file was written, taken): a checkpoint as each steerlab version wrote it, and as another tool wrote
    a sealed one again."""
    return [("sealed", True), ("0.1.0", True), ("first versions", True), ("torch.save of a sealed one", False),
            ("torch.save of one with an inner hash", False), ("torch.save of an earlier version's, format changed",
                                                               False)]


@pytest.mark.parametrize("how, taken", rule5_cases(), ids=str)
def test_rule5_only_earlier_versions_are_taken_as_earlier_versions(how, taken, tmp_path):
    import torch

    from steerlab.checkpoint import FORMAT, content_hash, load_checkpoint

    path = made(tmp_path)
    raw = torch.load(path, weights_only=True)
    if how == "0.1.0":
        path = Path(__file__).parents[1] / "fixtures" / "run-0.1.0" / "best.pt"
    elif how == "first versions":
        torch.save({**raw, "format": "steerlab-checkpoint-1"}, path)
    elif how == "torch.save of a sealed one":
        torch.save(raw, path)
    elif how == "torch.save of one with an inner hash":
        earlier = {**raw, "format": "steerlab-checkpoint-1"}
        torch.save({**earlier, "content_sha256": content_hash(earlier)}, path)
    elif how != "sealed":
        torch.save({**raw, "format": FORMAT}, path)
    if taken:
        assert load_checkpoint(path)["model"] in ("pilotnet", "cg23")  # 0.1.0's run trained cg23
        return
    with pytest.raises(SteerlabError, match=f"^{path}: a checkpoint that steerlab sealed, without its seal"):
        load_checkpoint(path)


def test_an_unsealed_file_with_bytes_after_its_end_record_is_damaged_not_an_earlier_version(tmp_path):
    """The seal by hand: torch.save's own file (no comment, its end record last) is an earlier version's (None); the
    same with bytes after it (a copy that went wrong) is damaged (False), as is a sealed file with one byte more."""
    import io

    import torch

    from steerlab.checkpoint import _seal_intact, save_payload

    buf = io.BytesIO()
    torch.save({"a": torch.zeros(2)}, buf)
    plain = buf.getvalue()
    assert _seal_intact(plain) is None and _seal_intact(plain + b"\0" * 5) is False
    assert _seal_intact(plain + b"junk") is False
    save_payload(tmp_path / "sealed.pt", {"a": torch.zeros(2)})
    sealed = (tmp_path / "sealed.pt").read_bytes()
    assert _seal_intact(sealed) is True and _seal_intact(sealed + b"\0") is False
