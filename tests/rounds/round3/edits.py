"""Group C of the third round, its edits: how a copy of a fixture is saved or edited by hand in plausible wrong
ways (EDITS: name, the fixture copied, the edit, the command on the copy, hint, expect)."""

import json
import shutil

import numpy as np

from tests.rounds.round3.common import SIM, TUB, CH2


# C. real-world data mistakes: a copy of a fixture edited by `edit`, then a command on it ({copy})
def _records(d):
    return [json.loads(line) for line in (d / "catalog_0.catalog").read_text().splitlines() if line.strip()]


def _write_records(d, recs, keep_manifest=False):
    lines = [json.dumps(r) for r in recs]
    (d / "catalog_0.catalog").write_text("\n".join(lines) + "\n")
    if not keep_manifest:
        m = json.loads((d / "catalog_0.catalog_manifest").read_text())
        m["line_lengths"] = [len(line) + 1 for line in lines]
        (d / "catalog_0.catalog_manifest").write_text(json.dumps(m) + "\n")


def _record(i, **kw):
    def f(d):
        recs = _records(d)
        for k, v in kw.items():
            k = k.replace("__", "/")
            if v is _DROP:
                recs[i].pop(k, None)
            else:
                recs[i][k] = v
        _write_records(d, recs)
    return f


_DROP = object()


def _manifest(line, **kw):
    def f(d):
        lines = (d / "manifest.json").read_text().splitlines()
        m = json.loads(lines[line])
        m.update(kw)
        lines[line] = json.dumps(m)
        (d / "manifest.json").write_text("\n".join(lines) + "\n")
    return f


def _manifest_text(change):
    def f(d):
        (d / "manifest.json").write_text(change((d / "manifest.json").read_text()))
    return f


def _bytes(name, change):
    def f(d):
        p = d / name
        p.write_bytes(change(p.read_bytes()))
    return f


def _images(size, pattern, which=None, gray=False):
    import cv2

    def f(d):
        frames = sorted(d.rglob(pattern))
        for fr in frames if which is None else [frames[which]]:
            img = np.full((*size, 3), 90, np.uint8)
            cv2.imwrite(str(fr), cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if gray else img)
    return f


def _lines(name, change):
    """The lines of the file `name` in the copy changed by `change(lines) -> lines` (text)."""
    def f(d):
        p = d / name
        p.write_text("\n".join(change(p.read_text().splitlines())) + "\n")
    return f


def _log(change):
    """The driving log's lines changed by `change(lines) -> lines` (text)."""
    return _lines("driving_log.csv", change)


def _cols(fn):
    return _log(lambda lines: [",".join(fn(line.split(","), i)) for i, line in enumerate(lines)])


def _set(col, value, rows=None):
    return _cols(lambda c, i: c[:col] + [value if callable(value) is False else value(c[col])] + c[col + 1:]
                 if rows is None or i in rows else c)


def _labels(change):
    return _lines("labels.csv", change)


def _png_as_jpg(d):
    import cv2

    fr = sorted((d / "images").glob("*.jpg"))[2]
    cv2.imwrite(str(fr.with_suffix(".png")), np.full((120, 160, 3), 90, np.uint8))
    fr.with_suffix(".png").replace(fr)


def _empty_image(d):
    sorted((d / "images").glob("*.jpg"))[2].write_bytes(b"")


def _half_image(d):
    p = sorted((d / "images").glob("*.jpg"))[2]
    p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2])


def _blank_line(d):
    recs = (d / "catalog_0.catalog").read_text().splitlines()
    (d / "catalog_0.catalog").write_text("\n".join(recs[:4] + [""] + recs[4:]) + "\n")


def _edit_catalog_by_hand(d):  # a value changed in an editor: the line's length no longer the manifest's
    text = (d / "catalog_0.catalog").read_text().replace('"user/angle": 0.1', '"user/angle": 0.15', 1)
    (d / "catalog_0.catalog").write_text(text)


def _renamed_key(d):
    recs = _records(d)
    for r in recs:
        r["angle"] = r.pop("user/angle")
    _write_records(d, recs)


def _seconds(d):
    recs = _records(d)
    for r in recs:
        r["_timestamp_ms"] = r["_timestamp_ms"] / 1000.0
    _write_records(d, recs)


def _images_renamed(d):
    for p in (d / "images").glob("*.jpg"):
        p.rename(p.with_name(p.name.replace("_cam_image_array_", "")))


def _catalog_removed(d):
    (d / "catalog_0.catalog").unlink()
    (d / "catalog_0.catalog_manifest").unlink()


def _two_catalogs_one_listed(d):  # a second catalog on disk that the manifest does not list
    shutil.copy(d / "catalog_0.catalog", d / "catalog_1.catalog")


def _tub_v1(d):  # donkeycar's old tub v1 layout: record_N.json files, meta.json
    for i, r in enumerate(_records(d)):
        (d / f"record_{i}.json").write_text(json.dumps({"cam/image_array": r["cam/image_array"],
                                                        "user/angle": r["user/angle"],
                                                        "user/throttle": r["user/throttle"]}))
    for name in ("catalog_0.catalog", "catalog_0.catalog_manifest", "manifest.json"):
        (d / name).unlink()
    (d / "meta.json").write_text(json.dumps({"inputs": ["cam/image_array", "user/angle", "user/throttle"],
                                             "types": ["image_array", "float", "float"]}))


def _wood_cut(d, update=False):
    """The real wood-tape tub cut by hand to its first catalog (its first 1000 records): the manifest updated
    or, as a hurried owner does, not."""
    if update:
        _manifest(4, paths=["catalog_0.catalog"], current_index=1000)(d)


def _windows_paths(lines):
    out = []
    for line in lines:
        c = line.split(",")
        c[0] = "C:\\Users\\me\\Desktop\\data\\IMG\\" + c[0].split("/")[-1]
        out.append(",".join(c))
    return out


def _cr_only(d):
    p = d / "driving_log.csv"
    p.write_bytes(p.read_bytes().replace(b"\n", b"\r"))


def _mixed_endings(d):
    p = d / "driving_log.csv"
    lines = p.read_bytes().split(b"\n")
    p.write_bytes(b"\r\n".join(lines[:4]) + b"\n" + b"\n".join(lines[4:]))


def _bom_header(d):
    p = d / "driving_log.csv"
    p.write_bytes(b"\xef\xbb\xbfcenter,left,right,steering,throttle,brake,speed\r\n"
                  + p.read_bytes().replace(b"\n", b"\r\n"))


def _utf16_bom_labels(d):
    p = d / "labels.csv"
    p.write_bytes(p.read_text().encode("utf-16-le").join([b"\xff\xfe", b""]))


def _excel_labels(lines):  # saved by a European Excel: semicolons, decimal commas
    return [lines[0].replace(",", ";")] + [";".join(v.replace(".", ",") for v in line.split(",")) for line in lines[1:]]


def _scientific_ids(lines):  # frame ids as Excel shows them
    return [lines[0]] + [",".join([f"{int(line.split(',')[0]):.4E}", *line.split(",")[1:]]) for line in lines[1:]]


def _degrees_labels(lines):
    return [lines[0]] + [",".join([c[0], f"{float(c[1]) * 57.3 + 5 * i:.2f}", c[2]])
                         for i, c in enumerate(line.split(",") for line in lines[1:])]


EDITS = {  # name: (fixture copied, the edit, the command on the copy, hint, expect)
    # tubs: catalog and manifest edited by hand
    "tub: an angle in degrees": (TUB, _record(3, user__angle=12.5), "compile", ["catalog_0.catalog", "user/angle"]),
    "tub: an angle as a text": (TUB, _record(3, user__angle="0.1"), "compile", ["catalog_0.catalog", "user/angle"]),
    "tub: an angle null": (TUB, _record(3, user__angle=None), "compile", ["catalog_0.catalog", "user/angle"]),
    "tub: an angle NaN": (TUB, _bytes("catalog_0.catalog", lambda b: b.replace(b'"user/angle": 0.1', b'"user/angle":'
                                                                                 b' NaN', 1)), "compile",
                          ["catalog_0.catalog", "user/angle", "NaN"]),
    "tub: a throttle in percent": (TUB, _record(2, user__throttle=30), "compile", ["catalog_0.catalog",
                                                                                   "user/throttle"]),
    "tub: a record without its throttle": (TUB, _record(2, user__throttle=_DROP), "compile",
                                           ["catalog_0.catalog", "user/throttle"], "ok"),  # compile reads none
    "tub: a record without its image key": (TUB, _record(2, cam__image_array=_DROP), "compile",
                                            ["catalog_0.catalog", "cam/image_array"]),
    "tub: user/angle renamed angle in every record": (TUB, _renamed_key, "compile", ["user/angle"]),
    "tub: an _index twice": (TUB, _record(4, _index=3), "compile", ["catalog_0.catalog", "_index", "3"]),
    "tub: an _index as a text": (TUB, _record(4, _index="4"), "compile", ["catalog_0.catalog", "_index"]),
    "tub: a timestamp going back": (TUB, _record(5, _timestamp_ms=900), "compile",
                                    ["timestamps", "frame 5"], "warn"),
    "tub: timestamps in seconds": (TUB, _seconds, "compile", ["_timestamp_ms", "catalog_0.catalog"], "warn"),
    "tub: an image named .png": (TUB, _record(3, cam__image_array="3_cam_image_array_.png"), "compile",
                                 ["3_cam_image_array_.png"]),
    "tub: an image named by its path": (TUB, _record(3, cam__image_array="images/3_cam_image_array_.jpg"),
                                        "compile", ["images/3_cam_image_array_.jpg"], "ok"),
    "tub: the images renamed": (TUB, _images_renamed, "compile", ["0_cam_image_array_.jpg", "images"]),
    "tub: a PNG saved as .jpg": (TUB, _png_as_jpg, "compile", ["2_cam_image_array_.jpg"], "ok"),
    "tub: an empty image": (TUB, _empty_image, "compile", ["2_cam_image_array_.jpg"]),
    "tub: half an image": (TUB, _half_image, "compile", ["2_cam_image_array_.jpg"]),
    "tub: a gray JPEG among colour ones": (TUB, _images((120, 160), "*.jpg", 3, gray=True), "compile",
                                           ["3_cam_image_array_.jpg"], "ok"),
    "tub: every image 320x240": (TUB, _images((240, 320), "*.jpg"), "evaluate", ["320x240", "donkey", "160x120"]),
    "tub: one image 320x240": (TUB, _images((240, 320), "*.jpg", 3), "compile", ["3_cam_image_array_.jpg"]),
    "tub: every image 224x224": (TUB, _images((224, 224), "*.jpg"), "evaluate", ["224x224", "160x120"]),
    "tub: manifest paths a missing catalog": (TUB, _manifest(4, paths=["catalog_0.catalog", "catalog_1.catalog"]),
                                              "compile", ["catalog_1.catalog"]),
    "tub: manifest paths empty": (TUB, _manifest(4, paths=[]), "compile", ["manifest.json", "paths"]),
    "tub: manifest paths a text": (TUB, _manifest(4, paths="catalog_0.catalog"), "compile",
                                   ["manifest.json", "paths"]),
    "tub: manifest deleted_indexes as texts": (TUB, _manifest(4, deleted_indexes=["2"]), "compile",
                                               ["manifest.json", "deleted_indexes"]),
    "tub: manifest deleted_indexes all": (TUB, _manifest(4, deleted_indexes=list(range(8))), "compile",
                                          ["deleted", "tub"]),
    "tub: manifest deleted_indexes a range text": (TUB, _manifest(4, deleted_indexes="2-4"), "compile",
                                                   ["manifest.json", "deleted_indexes"]),
    "tub: manifest current_index short": (TUB, _manifest(4, current_index=3), "compile", ["current_index"], "ok"),
    "tub: manifest of four lines": (TUB, _manifest_text(lambda t: "\n".join(t.splitlines()[:4]) + "\n"), "compile",
                                    ["manifest.json"]),
    "tub: manifest with a trailing comma": (TUB, _manifest_text(lambda t: t.replace("]}", "],}", 1)), "compile",
                                            ["manifest.json"]),
    "tub: manifest as one JSON document": (TUB, _manifest_text(lambda t: "[" + ",".join(t.splitlines()) + "]\n"),
                                           "compile", ["manifest.json"]),
    "tub: manifest CRLF": (TUB, _manifest_text(lambda t: t.replace("\n", "\r\n")), "compile", ["manifest.json"],
                           "ok"),
    "tub: manifest with a BOM": (TUB, _manifest_text(lambda t: "\ufeff" + t), "compile", ["manifest.json"], "ok"),
    "tub: manifest removed": (TUB, lambda d: (d / "manifest.json").unlink(), "compile", ["manifest.json"]),
    "tub: catalogs removed": (TUB, _catalog_removed, "compile", ["catalog_0.catalog"]),
    "tub: a catalog on disk not in the manifest": (TUB, _two_catalogs_one_listed, "compile", ["catalog_1.catalog"],
                                                   "ok"),  # as donkeycar reads a tub: its manifest's catalogs
    "tub: catalog CRLF": (TUB, _bytes("catalog_0.catalog", lambda b: b.replace(b"\n", b"\r\n")), "compile",
                          ["catalog_0.catalog"], "ok"),
    "tub: catalog with a BOM": (TUB, _bytes("catalog_0.catalog", lambda b: b"\xef\xbb\xbf" + b), "compile",
                                ["catalog_0.catalog"], "ok"),
    "tub: a blank line in the catalog": (TUB, _blank_line, "compile", ["catalog_0.catalog"], "ok"),
    "tub: a value edited by hand (line lengths off)": (TUB, _edit_catalog_by_hand, "compile",
                                                       ["catalog_0.catalog"], "ok"),
    "tub: catalog_manifest removed": (TUB, lambda d: (d / "catalog_0.catalog_manifest").unlink(), "compile",
                                      ["catalog_0.catalog_manifest"], "ok"),
    "tub: a catalog record with single quotes": (TUB, _bytes("catalog_0.catalog", lambda b: b.replace(b'"user/mode": '
                                                 b'"user"', b"'user/mode': 'user'", 1)), "compile",
                                                 ["catalog_0.catalog"], "warn"),
    "tub: donkeycar's old v1 layout": (TUB, _tub_v1, "compile", ["tub", "v1", "record_"]),
    "tub: pilot-mode records": (TUB, _record(3, user__mode="local"), "compile", ["user/mode"], "ok"),
    # driving logs
    "log: Windows paths": (SIM, _log(_windows_paths), "compile", ["driving_log.csv"], "ok"),
    "log: a header row": (SIM, _log(lambda ls: ["center,left,right,steering,throttle,brake,speed", *ls]), "compile",
                          ["driving_log.csv"], "ok"),
    "log: a header row with a BOM, CRLF": (SIM, _bom_header, "compile", ["driving_log.csv"], "ok"),
    "log: semicolons": (SIM, _log(lambda ls: [line.replace(",", ";") for line in ls]), "compile",
                        ["driving_log.csv"]),
    "log: European Excel (semicolons, decimal commas)": (SIM, _log(lambda ls: [";".join(c.replace(".", ",")
                                                                                        if "/" not in c else c
                                                                                        for c in line.split(","))
                                                                               for line in ls]), "compile",
                                                         ["driving_log.csv"]),
    "log: tabs": (SIM, _log(lambda ls: [line.replace(",", "\t") for line in ls]), "compile", ["driving_log.csv"]),
    "log: spaces after commas": (SIM, _log(lambda ls: [line.replace(",", ", ") for line in ls]), "compile",
                                 ["driving_log.csv"], "ok"),
    "log: quoted fields": (SIM, _log(lambda ls: [",".join(f'"{c}"' for c in line.split(",")) for line in ls]),
                           "compile", ["driving_log.csv"], "ok"),
    "log: relative paths": (SIM, _cols(lambda c, i: ["IMG/" + c[0].split("/")[-1], *c[1:]]), "compile",
                            ["driving_log.csv"], "ok"),
    "log: steering in degrees": (SIM, _set(3, "12.5", {2}), "compile", ["driving_log.csv", "steering", "3"]),
    "log: throttle in percent": (SIM, _set(4, "50", {2}), "compile", ["driving_log.csv", "throttle"]),
    "log: speed in km/h": (SIM, _set(6, "110"), "compile", ["driving_log.csv", "speed"], "warn"),
    "log: speed negative": (SIM, _set(6, "-3", {1}), "compile", ["driving_log.csv", "speed"]),
    "log: steering a text": (SIM, _set(3, "left", {1}), "compile", ["driving_log.csv", "left"]),
    "log: steering empty": (SIM, _set(3, "", {1}), "compile", ["driving_log.csv", "steering"]),
    "log: six columns (no speed)": (SIM, _cols(lambda c, i: c[:6]), "compile", ["driving_log.csv", "7"]),
    "log: a row of six columns": (SIM, _cols(lambda c, i: c[:6] if i == 3 else c), "compile",
                                  ["driving_log.csv", "4"]),
    "log: an image that is not there": (SIM, _cols(lambda c, i: [c[0].replace("000.jpg", "050.jpg"), *c[1:]]),
                                        "compile", ["center_2020_01_01_00_00_00_050.jpg"]),
    "log: the same row twice": (SIM, _log(lambda ls: ls[:3] + ls[2:]), "compile", ["driving_log.csv", "twice",
                                                                                   "center_"], "warn"),
    "log: rows out of time order": (SIM, _log(lambda ls: [ls[0], ls[2], ls[1], *ls[3:]]), "compile",
                                    ["driving_log.csv", "order", "center_"], "warn"),
    "log: CR line endings (old Mac)": (SIM, _cr_only, "compile", ["driving_log.csv"], "ok"),
    "log: mixed line endings": (SIM, _mixed_endings, "compile", ["driving_log.csv"], "ok"),
    "log: renamed driving-log.csv": (SIM, lambda d: (d / "driving_log.csv").rename(d / "driving-log.csv"), "compile",
                                     ["driving_log.csv", "driving-log.csv", "sim"]),
    "log: IMG renamed img": (SIM, lambda d: (d / "IMG").rename(d / "img"), "compile", ["IMG", "center_"]),
    "log: IMG zipped away (IMG.zip)": (SIM, lambda d: (shutil.make_archive(str(d / "IMG"), "zip", d / "IMG"),
                                                       shutil.rmtree(d / "IMG")), "compile", ["IMG", "center_"]),
    # label files
    "labels: a French header": (CH2, _labels(lambda ls: ["frame_id,angle_de_braquage,public", *ls[1:]]), "compile",
                                ["labels.csv", "steering_angle"]),
    "labels: a German header": (CH2, _labels(lambda ls: ["bild_id,lenkwinkel,öffentlich", *ls[1:]]), "compile",
                                ["labels.csv", "frame_id"]),
    "labels: a Chinese header": (CH2, _labels(lambda ls: ["帧编号,转向角,公开", *ls[1:]]), "compile",
                                 ["labels.csv", "frame_id"]),
    "labels: a capitalised header": (CH2, _labels(lambda ls: ["Frame_ID,Steering_Angle,Public", *ls[1:]]), "compile",
                                     ["labels.csv", "frame_id"], "ok"),
    "labels: no header": (CH2, _labels(lambda ls: ls[1:]), "compile", ["labels.csv", "frame_id"]),
    "labels: in degrees": (CH2, _labels(_degrees_labels), "compile", ["labels.csv", "degrees"], "warn"),
    "labels: European Excel": (CH2, _labels(_excel_labels), "compile", ["labels.csv"]),
    "labels: frame ids in scientific notation": (CH2, _labels(_scientific_ids), "compile", ["labels.csv"]),
    "labels: frame ids as floats": (CH2, _labels(lambda ls: [ls[0]] + [line.replace(",", ".0,", 1) for line in ls[1:]]),
                                    "compile", ["labels.csv"], "ok"),
    "labels: no public column": (CH2, _labels(lambda ls: [line.rsplit(",", 1)[0] for line in ls]), "compile",
                                 ["labels.csv"], "ok"),
    "labels: UTF-16 with a BOM (Excel's Unicode text)": (CH2, _utf16_bom_labels, "compile", ["labels.csv"]),
    "labels: a frame id no image has": (CH2, _labels(lambda ls: ls[:3] + ["1234,0.0,1"] + ls[3:]), "compile",
                                        ["1234", "labels.csv"]),
    "labels: angle columns swapped with public": (CH2, _labels(lambda ls: ["frame_id,public,steering_angle"] +
                                                               ls[1:]), "compile", ["labels.csv"], "ok"),
    # the real tub cut by hand
    "wood-tape cut to one catalog, manifest left as it was": ("wood", _wood_cut, "compile", ["catalog_1.catalog"]),
    "wood-tape cut to one catalog, manifest updated": ("wood", lambda d: _wood_cut(d, True), "compile1000", [],
                                                       "ok"),
}
