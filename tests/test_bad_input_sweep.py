"""The bad-input sweep, kept: every bad command line gets one clear line and a non-zero exit.

Each row is a command line a hostile or hurried user may type, the exit code it must give
(2 bad input, 3 device, 4 file; click's own usage errors are 2 too, on one line naming the
command's --help) and words its one error line must hold. No row may end in a traceback or hang; `--debug` still shows the traceback.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import uuid
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.cli import cli

REPO = Path(__file__).resolve().parents[1]
OTHER = REPO / "data" / "twin-long-110mm"  # another build's files
RAW = REPO / "data" / "twin-paper-75mm" / "raw_grid.h5"
STUDY = REPO / "data" / "twin-paper-75mm" / "plane_study.h5"
CAL = REPO / "tests" / "fixtures" / "calibration-1.3.0-target.h5"

FILES = {
    "empty.h5": b"",
    "text.h5": b"hello\n",
    "garbage.toml": b"[grid\nfoo",
    "nan.toml": b"[grid]\nreach_min_mm = nan\n",
    "neg.toml": b"[grid]\nreach_min_mm = -5\n",
    "str.toml": b"[grid]\nreach_min_mm = \"a\"\n",
    "unknown.toml": b"[nosuch]\nx = 1\n",
    "inverted.toml": b"[grid]\nreach_min_mm = 60\nreach_max_mm = 50\n",
    "loss.toml": b"[safety]\nmax_frame_loss = 2\n",
    "nodepths.toml": b"[trials]\ndepths_mm = []\n",
    "nandepth.toml": b"[trials]\ndepths_mm = [5, nan]\n",
    "negtravel.toml": b"[trials]\ntravel_mm = -1\n",
    "tiny.csv": b"time,field\n0,1\n",
    "headeronly.csv": b"t,y\n",
    "empty.csv": b"",
    "left.h5.journal": b"{}\n",  # a run killed before its dataset was written leaves this alone
    # a Ø160 mm ring of points in metres, headerless, as a robot logs its contour
    "metres.csv": "".join(f"{0.5 + 0.08 * math.cos(a):.6f}, {0.08 * math.sin(a):.6f}\n"
                          for a in [k * math.pi / 20 for k in range(40)]).encode(),
    "three.csv": b"a,b,c\n1,2,3\n",
    "latin1.toml": b"[grid]\nreach_min_mm = 5 # \xe9\n",
    "deep.toml": b"a = " + b"[" * 3000 + b"]" * 3000 + b"\n",
    "tinystep.toml": b"[grid]\nstep_mm = 0.001\n",
    "tinymagnet.toml": b'sensor_id = "fine"\n[magnet.grid]\nrotation_step_rad = 1e-6\n',
    "keyevery.toml": b"[follow]\nkey_every = 1.5\n",
    "exists.h5": b"an earlier output",
    "exists.html": b"an earlier report",
    "rpexists/track.csv": b"an earlier track",
    "repexists/contour.json": b"{}",
    "odexists/errors.png": b"an earlier figure",
    "bnexists/bench.json": b"{}",
    "bnchart/surface-degree-truth.png": b"an earlier chart",
}
FILES["evaluation.json"] = FILES["metres.csv"]  # points where an evaluation would write its JSON

STAGE, SENSOR = "sim://{w}/stage", "sim://{w}/sensor"
COLLECT = ["collect", "--stage", STAGE, "--sensor", SENSOR]
STUDY_RUN = ["optimal-depth", "run", "--stage", STAGE + "?scene=plane", "--sensor", SENSOR]

# (command line, exit code, words the error line holds)
CASES = [
    ("fit nosuch.h5 --out o.h5", 4, "no such file"),
    ("fit empty.h5 --out o.h5", 4, "not an HDF5 file"),
    ("fit text.h5 --out o.h5", 4, "not an HDF5 file"),
    ("fit trunc_raw.h5 --out o.h5", 4, "truncated: 20000 of"),
    ("fit cal.h5 --out o.h5", 4, "not a whiskercal.raw_grid file"),
    ("fit study.h5 --out o.h5", 4, "not a whiskercal.raw_grid file"),
    ("fit raw.h5 --out raw.h5", 2, "an input is never overwritten"),
    ("fit adir --out o.h5", 2, "is a directory"),
    ("fit raw.h5 --out o.h5 --degree -3", 2, "degree must be 1..8"),
    ("fit raw.h5 --out o.h5 --degree nan", 2, "--degree must be"),
    ("fit raw.h5 --out o.h5 --samples 1", 2, "not in the range"),
    ("fit raw.h5 --out o.h5 --trace-length-mm nan", 2, "trace_length_mm"),
    ("fit raw.h5 --out o.h5 --trace-length-mm -5", 2, "trace_length_mm"),
    ("fit raw.h5 --out o.h5 --trace-length-mm inf", 2, "trace_length_mm"),
    ("fit raw.h5 --out o.h5 --entry-radius-mm nan", 2, "--entry-radius-mm"),
    ("fit raw.h5 --out o.h5 --entry-radius-mm 50", 2, "--entry-radius-mm must lie between 0 and half"),
    ("fit raw.h5 --out o.h5 --max-extension-mm nan", 2, "max_extension_mm"),
    ("fit raw.h5 --out o.h5 --threshold-uT -5", 2, "collision threshold"),
    ("fit raw.h5 --out o.h5 --threshold-uT inf", 2, "collision threshold"),
    ("inspect nosuch.h5", 4, "no such file"),
    ("inspect trunc_raw.h5", 4, "truncated"),
    ("inspect text.h5", 4, "not an HDF5 file"),
    ("inspect study.h5", 4, "not a whiskercal calibration artifact or raw grid"),
    ("report raw.h5 --out r.html", 4, "not a whiskercal.calibration file"),
    ("report cal.h5 --out cal.h5", 2, "an input is never overwritten"),
    ("report cal.h5 --out r.html --raw cal.h5", 4, "not a whiskercal.raw_grid file"),
    ("report cal.h5 --out r.html --study trunc_study.h5", 4, "truncated"),
    ("report cal.h5 --out r.html --bench nosuch", 2, "holds no bench.json"),
    ("optimal-depth report study.h5 --artifact raw.h5 --out od", 4, "not a whiskercal.calibration"),
    ("optimal-depth report raw.h5 --artifact cal.h5 --out od", 4, "not a whiskercal.plane_study"),
    ("optimal-depth report study.h5 --artifact cal.h5 --out od --margin-weight nan", 2, "--margin-weight"),
    ("optimal-depth report study.h5 --artifact cal.h5 --out od --margin-weight -1", 2, "--margin-weight"),
    ("optimal-depth report study.h5 --artifact cal.h5 --out od --out-artifact cal.h5", 2, "never overwritten"),
    ("replay nosuch.csv --artifact cal.h5 --out rp", 2, "cannot read the stream"),
    ("replay empty.csv --artifact cal.h5 --out rp", 2, "no header line"),
    ("replay headeronly.csv --artifact cal.h5 --out rp", 2, "no samples"),
    ("replay tiny.csv --artifact cal.h5 --out rp", 2, "no field column"),
    ("replay tiny.csv --artifact cal.h5 --out rp --field-column field --rest-uT nan", 2, "rest reading"),
    ("replay tiny.csv --artifact cal.h5 --out rp --delimiter xyz", 2, "delimiter must be"),
    ("replay tiny.csv --artifact raw.h5 --out rp", 4, "not a whiskercal.calibration"),
    ("replay cal.h5 --artifact cal.h5 --out rp", 4, "holds no stream to replay"),
    ("twin describe nosuch", 2, "unknown sensor"),
    ("twin describe garbage.toml", 2, "not valid TOML"),
    ("twin describe twin-paper-75mm --depth nan", 2, "the depth"),
    ("twin describe twin-paper-75mm --depth 1000", 2, "the depth"),
    ("regress nosuch", 2, "no such directory"),
    ("regress adir", 2, "no dataset directories"),
    ("bench --out cal.h5 --quick --only model-speed", 2, "is a file"),
    ("contour run --shape teapot --artifact cal.h5 --out c.h5", 2, "unknown shape 'teapot'"),
    ("contour run --shape cylinder --artifact nosuch.h5 --out c.h5", 4, "no such file"),
    ("contour run --shape cylinder --artifact raw.h5 --out c.h5", 4, "not a whiskercal.calibration"),
    ("contour run --shape cylinder --artifact cal.h5 --out cal.h5", 2, "never overwritten"),
    ("contour run --shape octagon --artifact cal.h5 --out c.h5 --mu-static 0.1 --mu-kinetic 0.2", 2,
     "must be at least --mu-kinetic"),
    ("contour run --shape octagon --artifact cal.h5 --out c.h5 --mu-static inf", 2, "--mu-static must be"),
    ("contour run --robot http://x:9090 --artifact cal.h5 --out c.h5", 2, "--robot must be rosbridge://"),
    ("contour run --robot rosbridge://127.0.0.1:9 --artifact cal.h5 --out c.h5 --box 1,2", 2, "--box must be"),
    ("contour run --robot rosbridge://127.0.0.1:9 --artifact cal.h5 --out c.h5 --watchdog-ms nan", 2,
     "--watchdog-ms must be"),
    ("contour run --artifact cal.h5 --out c.h5 --dry-run", 2, "--dry-run drives a robot"),
    ("contour run --shape cylinder --artifact cal.h5 --out c.h5 --mount-error 1,2,nan", 2,
     "--mount-error deg must be"),
    ("contour run --shape cylinder --artifact cal.h5 --out c.h5 --mount-error 90,0,0", 2,
     "--mount-error dx must be"),
    ("mount-cal --artifact cal.h5 --out m.toml --object circle:d=0", 2, "--object d must be"),
    ("mount-cal --artifact cal.h5 --out m.toml --robot sim://cylinder?seed=-1", 2, "seed"),
    ("mount-cal --artifact nosuch.h5 --out m.toml", 4, "no such file"),
    ("mount-cal --artifact cal.h5 --out m.toml --arc 400", 2, "--arc must be"),
    ("contour report raw.h5 --out rep", 4, "not a whiskercal.contour_run file"),
    ("contour report trunc_raw.h5 --out rep", 4, "truncated"),
    ("contour evaluate nosuch.csv --outline circle:d=160", 2, "cannot read the points"),
    ("contour evaluate adir --outline circle:d=160", 2, "is a directory"),
    ("contour evaluate empty.csv --outline circle:d=160", 2, "no points"),
    ("contour evaluate headeronly.csv --outline circle:d=160", 2, "header but no points"),
    ("contour evaluate three.csv --outline circle:d=160", 2, "which columns are x and y"),
    ("contour evaluate tiny.csv --outline circle:d=160", 2, "at least 10 distinct points"),
    ("contour evaluate metres.csv --outline circle:d=160", 2, "other units? --units m"),
    ("contour evaluate metres.csv --outline circle:d=400 --units m --fit similarity", 2,
     "scales the outline by 0.4"),
    ("contour evaluate raw.h5 --outline circle:d=160", 2, "holds no points"),
    ("contour evaluate trunc_raw.h5 --outline circle:d=160", 4, "truncated"),
    ("contour evaluate raw.h5 --outline circle:d=160 --units m", 2, "--units applies to text tables"),
    ("contour evaluate metres.csv --outline circle:d=160 --units km", 2, "Invalid value for '--units'"),
    ("contour evaluate metres.csv --outline teapot:d=1", 2, "use circle:d=D"),
    ("contour evaluate metres.csv --outline circle:d=nan", 2, "d must be a finite number > 0"),
    ("contour evaluate metres.csv --outline circle:d=160,w=3", 2, "'w=3' is not one of d="),
    ("contour evaluate metres.csv --outline rounded-rect:w=160,h=160,r=90", 2, "r must be less than half"),
    ("contour evaluate metres.csv --outline polygon:n=2,side=70", 2, "n must be an integer >= 3"),
    ("contour evaluate metres.csv --outline polyline:nosuch.txt", 2, "cannot read it"),
    ("contour evaluate metres.csv --outline polyline:three.csv", 2, "line 1 has 3 fields"),
    ("contour evaluate metres.csv --outline circle:d=160 --pose 1,2", 2, "--pose must be x,y,deg"),
    ("contour evaluate metres.csv --outline circle:d=160 --pose 1,inf,0", 2, "--pose y must be"),
    ("contour evaluate metres.csv --outline circle:d=160 --fit affine", 2, "Invalid value for '--fit'"),
    ("contour evaluate evaluation.json --outline circle:d=160 --units m --out .", 2, "never overwritten"),
    # click's usage errors: one line naming the --help that explains them
    ("fit raw.h5", 2, "Missing option '--out'; see 'whiskercal fit --help'"),
    ("fit raw.h5 --out o.h5 --bogus", 2, "see 'whiskercal fit --help'"),
    ("nosuch-command", 2, "No such command 'nosuch-command'; see 'whiskercal --help'"),
    # files that are not regular files, or that reach outside themselves
    ("inspect fifo.h5", 4, "is a FIFO, not a regular file"),
    ("fit fifo.h5 --out o.h5", 4, "is a FIFO, not a regular file"),
    ("twin describe fifo.toml", 2, "is a FIFO, not a regular file"),
    ("inspect soft.h5", 4, "/extra is a soft link: refused"),
    ("inspect external.h5", 4, "/outside is an external link: refused"),
    ("inspect loop.h5", 4, "is a soft link: refused"),
    ("inspect extstore.h5", 4, "dataset /outside is stored outside the file: refused"),
    ("report soft.h5 --out r.html", 4, "soft link: refused"),
    ("contour run --shape cylinder --artifact external.h5 --out c.h5", 4, "external link: refused"),
    ("replay tiny.csv --artifact soft.h5 --out rp", 4, "soft link: refused"),
    ("report cal.h5 --out r.html --raw soft_raw.h5", 4, "soft link: refused"),
    # malformed files of a known schema
    ("inspect nojson.h5", 4, "malformed calibration artifact"),
    ("report nanthreshold.h5 --out r.html", 4, "a finite collision threshold"),
    ("fit short_raw.h5 --out o.h5", 4, "malformed raw grid"),
    ("report cal.h5 --out r.html --study textdepth_study.h5", 4, "malformed study file"),
    ("fit flipped_raw.h5 --out o.h5", 2, "reads against the twin's truth"),
    # TOML that is not UTF-8 or nests too deeply; settings of the wrong type
    ("twin describe latin1.toml", 2, "not UTF-8"),
    ("twin describe deep.toml", 2, "nested too deep"),
    ("twin describe tinymagnet.toml", 2, "choose coarser steps"),
    ("contour run --shape cylinder --artifact cal.h5 --out c.h5 --config keyevery.toml", 2,
     "key_every: must be an integer"),
    # inputs from another sensor
    ("report cal.h5 --out r.html --raw raw110.h5", 2, "pass --allow-other-sensor"),
    ("report cal.h5 --out r.html --study study110.h5", 2, "recorded on sensor 'long-110mm'"),
    ("optimal-depth report study110.h5 --artifact cal.h5 --out od", 2, "pass --allow-other-sensor"),
    # the same sensor id: another raw grid than the one fitted, another plan, another target's study
    ("report cal.h5 --out r.html --raw raw.h5", 2, "is not the one the calibration was fitted from"),
    ("report cal.h5 --out r.html --study reach90_study.h5", 2,
     "planned for a whisker of 90 mm to its tip, the calibration traces 78 mm"),
    ("report othertarget.h5 --out r.html --study study.h5", 2,
     "is not the one the calibration was given its target by"),
    ("optimal-depth report reach90_study.h5 --artifact cal.h5 --out od", 2,
     "planned for a whisker of 90 mm"),
    # refused before the run
    ("contour run --shape cylinder --artifact cal.h5 --out c.h5 --seed -1", 2, "--seed must be an integer >= 0"),
    ("contour run --shape cylinder --artifact cal.h5 --out c.h5 --seed 12345678901234567890", 2,
     "--seed must be an integer <= 4294967295"),
    ("contour run --shape cylinder --artifact cal.h5 --out c.h5 --target-uT 100", 2,
     "outside cal.h5's calibrated range"),
    ("contour run --shape cylinder --artifact cal.h5 --out c.h5 --target-uT 0", 2, "outside"),
    ("contour run --shape cylinder --artifact cal.h5 --out c.h5 --target-uT -99999", 2, "outside"),
    # an existing output is refused without --force
    ("fit raw.h5 --out exists.h5", 2, "exists.h5 already exists: pass --force"),
    ("report cal.h5 --out exists.html", 2, "already exists: pass --force"),
    ("contour run --shape cylinder --artifact cal.h5 --out exists.h5", 2, "already exists"),
    ("contour report raw.h5 --out repexists", 2, "contour.json already exists"),
    ("optimal-depth report study.h5 --artifact cal.h5 --out od --out-artifact exists.h5", 2,
     "already exists: pass --force"),
    ("optimal-depth report study.h5 --artifact cal.h5 --out odexists", 2, "errors.png already exists"),
    ("replay tiny.csv --artifact cal.h5 --out rpexists", 2, "track.csv already exists"),
    ("bench --quick --only field-speed --out bnexists", 2, "bench.json already exists: pass --force"),
    ("bench --quick --only surface-degree --out bnchart", 2,
     "surface-degree-truth.png already exists: pass --force"),
] + [(" ".join(COLLECT + extra.split()), code, words) for extra, code, words in [
    ("--out c.h5 --config nosuch.toml", 2, "no such config file"),
    ("--out c.h5 --config garbage.toml", 2, "not valid TOML"),
    ("--out c.h5 --config nan.toml", 2, "[grid] reach_min_mm: must be a finite number, not nan"),
    ("--out c.h5 --config neg.toml", 2, "[grid] reach_min_mm: must be a number >= 0, not -5"),
    ("--out c.h5 --config str.toml", 2, '[grid] reach_min_mm: must be a number >= 0, not "a"'),
    ("--out c.h5 --config unknown.toml", 2, "[nosuch]: unknown table"),
    ("--out c.h5 --config inverted.toml", 2, "reach_min_mm < reach_max_mm"),
    ("--out c.h5 --config loss.toml", 2, "max_frame_loss"),
    ("--out c.h5 --plan nonsense", 2, "unknown plan 'nonsense'; choose from full, quick"),
    ("--dry-run --plan QUICK", 2, "unknown plan 'QUICK'; choose from full, quick"),
    ("--out raw.h5", 2, "already exists: pass --force to replace it, or --resume"),
    ("--out raw.h5 --force --resume", 2, "--force replaces it: give one"),
    ("--out left.h5 --force", 2, "journal of an interrupted run"),  # a partial run is resumed
    ("--out left.h5", 2, "left.h5.journal is the journal of an interrupted run"),
    ("--out c.h5 --resume", 2, "nothing to resume"),
    ("--out trunc_raw.h5 --resume", 2, "truncated"),
    ("--out study.h5 --resume", 2, "cannot resume"),
    ("--out adir", 2, "is a directory"),
    ("--out c.h5 --config latin1.toml", 2, "not UTF-8"),
    ("--out c.h5 --config deep.toml", 2, "nested too deep"),
    ("--out c.h5 --config fifo.toml", 2, "is a FIFO, not a regular file"),
    ("--out c.h5 --config tinystep.toml", 2, "choose a coarser step"),
    ("--out fifo.h5 --resume", 2, "fifo.h5: is a FIFO, not a regular file: nothing to resume"),
]] + [
    ("collect --stage sim://{w}/stage?nosuch=1 --sensor " + SENSOR + " --out c.h5", 3, "unknown sim:// option"),
    ("collect --stage sim://{w}/stage?seed=abc --sensor " + SENSOR + " --out c.h5", 2, "seed must be an integer"),
    ("collect --stage sim://{w}/stage?speed=nan --sensor " + SENSOR + " --out c.h5", 2, "speed"),
    ("collect --stage sim://{w}/stage?drop=2 --sensor " + SENSOR + " --out c.h5", 2, "drop"),
    ("collect --stage sim://{w}/stage?stock=yes --sensor " + SENSOR + " --out c.h5", 2, "stock must be 0 or 1"),
    ("collect --stage sim://{w}/stage?scene=teapot --sensor " + SENSOR + " --out c.h5", 2, "unknown scene"),
    ("collect --stage sim://{w}/stage?fault=bogus --sensor " + SENSOR + " --out c.h5", 2, "bad fault"),
    ("collect --stage sim://{w}/stage?fault=stall@nan --sensor " + SENSOR + " --out c.h5", 2, "time of fault"),
    ("collect --stage sim://{w}/stage?sensor=nosuch.toml --sensor " + SENSOR + " --out c.h5", 2, "no such sensor file"),
    ("collect --stage sim://{w}/sensor --sensor sim://{w}/stage --out c.h5", 3, "did not answer"),
    ("collect --stage /dev/nosuch-port --sensor " + SENSOR + " --out c.h5", 3, "cannot open serial port"),
    ("collect --stage sim://{w}/stage?scene=plane --sensor " + SENSOR + " --out c.h5", 2,
     "carries the plane scene, not the rod"),
] + [(" ".join(STUDY_RUN + extra.split()), code, words) for extra, code, words in [
    ("--out s.h5 --config nodepths.toml", 2, "depths_mm"),
    ("--out s.h5 --config nandepth.toml", 2, "depths_mm"),
    ("--out s.h5 --config negtravel.toml", 2, "[trials] travel_mm: must be a number > 0, not -1"),
    ("--out study.h5", 2, "already exists: pass --force to replace it, or --resume"),
    ("--out study.h5 --force --resume", 2, "--force replaces it: give one"),
    ("--out trunc_study.h5 --resume", 4, "truncated"),
    ("--out raw.h5 --resume", 4, "not a whiskercal.plane_study file"),
]]

# `sim serve` runs until Ctrl-C when its checks fail to stop it: a subprocess with a time limit
SERVE_CASES = [
    ("--duration nan", "--duration"),
    ("--duration -1", "--duration"),
    ("--speed nan --duration 1", "--speed"),
    ("--speed 0 --duration 1", "--speed"),
    ("--rod-radius -1 --duration 1", "--rod-radius"),
    ("--fault missed_steps@nan --duration 1", "time of fault"),
    ("--fault bogus --duration 1", "bad fault"),
    ("--sensor nosuch --duration 1", "unknown sensor"),
]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    """Good and broken inputs side by side (a truncated copy keeps its first 20000 bytes)."""
    folder = tmp_path_factory.mktemp("sweep")
    for name, content in FILES.items():
        (folder / name).parent.mkdir(exist_ok=True)
        (folder / name).write_bytes(content)
    for source, name in ((RAW, "raw.h5"), (STUDY, "study.h5"), (CAL, "cal.h5"),
                         (OTHER / "raw_grid.h5", "raw110.h5"),
                         (OTHER / "plane_study.h5", "study110.h5")):
        shutil.copy(source, folder / name)
    for name in ("raw.h5", "study.h5"):
        (folder / f"trunc_{name}").write_bytes((folder / name).read_bytes()[:20000])
    (folder / "adir").mkdir()
    for name in ("fifo.h5", "fifo.toml"):
        os.mkfifo(folder / name)
    _linked_and_malformed(folder)
    return folder


def _edited(folder: Path, source: str, name: str, edit) -> None:
    shutil.copy(folder / source, folder / name)
    with h5py.File(folder / name, "a") as handle:
        edit(handle)


def _shortened(handle, name: str) -> None:
    values = handle[name][()]
    del handle[name]
    handle[name] = values[:-1]


def _y_flipped(handle) -> None:
    """The sensor's Y read the other way (points and baselines), the twin's truth left as it was."""
    for name in ("points/field_mean_uT", "baseline/before_field_uT", "baseline/after_field_uT"):
        values = handle[name][()]
        values[..., 1] *= -1
        handle[name][...] = values


def _set_config(handle, table: str, key: str, value) -> None:
    config = json.loads(handle.attrs["config"])
    config[table][key] = value
    handle.attrs["config"] = json.dumps(config)


def _text_attr(handle) -> None:
    trial = handle["trials"][sorted(handle["trials"])[0]]
    trial.attrs["depth_mm"] = "deep"


def _linked_and_malformed(folder: Path) -> None:
    """Copies of good files with a link, storage outside the file, or content its schema forbids."""
    (folder / "outside.bin").write_bytes(np.zeros(4).tobytes())
    edits = {
        "soft.h5": ("cal.h5", lambda h: h.__setitem__("extra", h5py.SoftLink("/lookup"))),
        "soft_raw.h5": ("raw.h5", lambda h: h.__setitem__("extra", h5py.SoftLink("/points"))),
        "external.h5": ("cal.h5", lambda h: h.__setitem__("outside", h5py.ExternalLink("raw.h5", "/"))),
        "loop.h5": ("cal.h5", lambda h: (h.__setitem__("a", h5py.SoftLink("/b")),
                                         h.__setitem__("b", h5py.SoftLink("/a")))),
        "extstore.h5": ("cal.h5", lambda h: h.create_dataset(
            "outside", shape=(4,), dtype="f8", external=[("outside.bin", 0, 32)])),
        "nojson.h5": ("cal.h5", lambda h: h.attrs.__setitem__("config", "{not json")),
        "nanthreshold.h5": ("cal.h5", lambda h: h["collision"].attrs.__setitem__("threshold_uT", np.nan)),
        "short_raw.h5": ("raw.h5", lambda h: _shortened(h, "points/field_mean_uT")),
        "textdepth_study.h5": ("study.h5", _text_attr),
        "flipped_raw.h5": ("raw.h5", _y_flipped),
        # the same sensor id, but a study planned for a longer whisker, and a target chosen by
        # another study than the one given
        "reach90_study.h5": ("study.h5", lambda h: _set_config(h, "geometry", "tip_reach_mm", 90.0)),
        "othertarget.h5": ("cal.h5", lambda h: h["target"].attrs.__setitem__("study_sha256",
                                                                             "ab" * 32)),
    }
    for name, (source, edit) in edits.items():
        _edited(folder, source, name, edit)


def _invoke(workdir: Path, line: str, *flags: str):
    words = line.format(w=f"sweep{uuid.uuid4().hex[:8]}").split()
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(workdir)
        return CliRunner().invoke(cli, [*flags, "-q", *words])


@pytest.mark.parametrize("line, code, words", CASES, ids=[case[0] for case in CASES])
def test_a_bad_command_line_gets_one_clear_error_line(workdir, line, code, words):
    before = {p.name: p.stat().st_mtime_ns for p in workdir.iterdir()}
    result = _invoke(workdir, line)
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exc_info
    assert result.exit_code == code, result.output
    errors = [text for text in result.stderr.splitlines() if text.lower().startswith("error:")]
    assert len(errors) == 1 and words in errors[0], result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    for name, stamp in before.items():  # a refused command changed no input
        assert (workdir / name).stat().st_mtime_ns == stamp, name


@pytest.mark.parametrize("options, words", SERVE_CASES, ids=[case[0] for case in SERVE_CASES])
def test_sim_serve_refuses_bad_options_at_once(options, words):
    done = subprocess.run([sys.executable, "-m", "whiskercal", "sim", "serve", *options.split()],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and words in lines[0], done.stderr


def test_debug_shows_the_traceback(workdir):
    result = _invoke(workdir, "fit nosuch.h5 --out o.h5", "--debug")
    assert result.exit_code != 0 and result.exception is not None
    assert type(result.exception).__name__ == "ArtifactError"
