"""Resources and ranges (issue 36, items 4, 7 and two messages of item 8).

A hostile input must not be able to take the machine: a YAML alias bomb, a huge list or
a huge file, an image that declares billions of pixels, `--workers 100000`; every numeric
field has a range (in the field, the same for scenarios and configurations);
a damaged image or video gives our one line on stderr and nothing from the C libraries;
and no message is longer than a few hundred characters. Real files, the real CLI; the
memory-hungry cases run in a child process under an address-space limit.
"""

from __future__ import annotations

import dataclasses as dc
import json
import math
import os
import struct
import subprocess
import sys
import textwrap
import time
import types
import typing
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from emonav_drake.config_fields import SEED_RANGE, WORLD_POINT, field_range
from emonav_drake.params import EmoNavConfig, load_config
from emonav_drake.perception.image_io import HARD_MAX_PIXELS, image_header_size
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams, HeadCameraParams
from emonav_drake.planners.specs import EXPERT_SPECS
from emonav_drake.scenarios.scenario import (
    MAX_SCHEDULE,
    PedestrianSpec,
    Scenario,
    StaticDiscSpec,
    WallSpec,
    load_scenario,
)
from emonav_drake.typed_yaml import MAX_YAML_BYTES, MAX_YAML_VALUES, ConfigError
from tests.cli_errors import assert_user_error, run

PACKAGE = Path(__file__).resolve().parent.parent / "emonav_drake"
TINY = "episode: {max_steps: 2}\n"
BIG = 16500  # 16500 x 16500 = 272 MP: just above the 268 MP (16384²) the tool decodes


@pytest.fixture
def tiny(tmp_path) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY)
    return path


def _child(code: str, *argv: object, limit_gb: float = 2.0, timeout: float = 120) -> tuple:
    """Run `code` in a fresh interpreter under an address-space limit of `limit_gb`:
    (exit code, stdout, stderr). `code` sees `argv` as sys.argv[1:]."""
    prologue = textwrap.dedent(
        f"""
        import resource, sys
        resource.setrlimit(resource.RLIMIT_AS, ({int(limit_gb * 2**30)}, {int(limit_gb * 2**30)}))

        def peak_mb():
            # this program's peak RSS [MB]: VmHWM (ru_maxrss keeps the forking parent's
            # peak across exec, so it would report pytest's size)
            status = open("/proc/self/status").read().splitlines()
            return int(next(x for x in status if x.startswith("VmHWM")).split()[1]) // 1024
        """
    )
    p = subprocess.run(
        [sys.executable, "-c", prologue + textwrap.dedent(code), *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=Path(__file__).resolve().parent.parent,
    )
    return p.returncode, p.stdout, p.stderr


# The CLI in a child process; prints its own peak RSS [MB] on stdout after the command.
CLI_WITH_PEAK = """
from emonav_drake.cli import main
code = main(sys.argv[1:])
print("PEAK_MB", peak_mb())
sys.exit(code)
"""


def _peak_mb(stdout: str) -> int:
    return int(stdout.split("PEAK_MB")[-1].split()[0])


# --- YAML: aliases, duplicate keys, sizes ---------------------------------------------------


def _alias_bomb(levels: int, where: str = "robot: {max_speed: *a%d}") -> str:
    """Each level a list of ten aliases of the previous one: 10**(levels + 1) values.

    The anchors sit under `_`-keys (Drake's loader drops root keys starting with `_`, the
    documented place for YAML templates), so only the last line is a field."""
    lines = ["_a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    for i in range(1, levels + 1):
        lines.append(f"_a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]")
    lines.append(where % levels)
    return "\n".join(lines) + "\n"


@pytest.mark.slow
def test_a_yaml_alias_bomb_is_refused_in_a_child_with_little_memory(tmp_path):
    # 9 levels: 10**10 values from 532 bytes. Before: 42 s and 4 GB (here: the 1.5 GB limit
    # hit, a traceback); now refused from the parser's events, nothing expanded
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(_alias_bomb(9))
    t0 = time.perf_counter()
    code, out, err = _child(CLI_WITH_PEAK, "config", "--config", bomb, limit_gb=1.5, timeout=90)
    assert time.perf_counter() - t0 < 60
    line = assert_user_error(code, err, str(bomb), "alias")
    assert len(err.strip().splitlines()) == 1, err
    assert len(line) < 400, line


@pytest.mark.parametrize(
    "argv, where",
    [
        (["config", "--config", "{f}"], "robot: {max_speed: *a%d}"),
        (["sim", "--scenario", "{f}", "--config", "{tiny}"], "robot_start: *a%d"),
        (["sim", "--emotion-estimate", "{f}", "--config", "{tiny}"], "confusion: *a%d"),
        (["train", "--config", "{f}", "--out", "{tmp}/run"], "seed: *a%d"),
        (["train", "--algo", "dagger", "--config", "{f}", "--out", "{tmp}/run"], "seed: *a%d"),
    ],
)
def test_every_yaml_door_refuses_an_alias_bomb(tmp_path, tiny, capsys, argv, where):
    # 10**6 values from 326 bytes: before, a 5 MB error line (or a long run)
    f = tmp_path / "bomb.yaml"
    f.write_text(_alias_bomb(5, where))
    args = [a.format(f=f, tiny=tiny, tmp=tmp_path) for a in argv]
    line = assert_user_error(*run(capsys, *args), str(f), "alias")
    assert len(line) < 400, line
    assert not (tmp_path / "run").exists()


def test_aliases_that_stay_small_still_work(tmp_path):
    # the templates Drake documents: an anchor used a few times
    f = tmp_path / "c.yaml"
    f.write_text(
        "_start: &s [-3.0, 0.5]\nrobot: {start: *s}\ncrowd: {static_x_range: [-2.0, 2.0]}\n"
    )
    assert load_config(f).robot.start == [-3.0, 0.5]


@pytest.mark.parametrize(
    "text, key, line",
    [
        ("robot:\n  max_speed: 0.3\n  max_speed: 0.5\n", "max_speed", 3),
        ("robot: {max_speed: 0.3}\nlidar: {num_beams: 900}\nrobot: {radius: 0.2}\n", "robot", 3),
        ("reward: {goal: 0.5, collision: -0.6, goal: 5.0}\n", "goal", 1),
    ],
)
def test_a_duplicate_key_is_refused_naming_file_key_and_line(tmp_path, capsys, text, key, line):
    # before: the last one silently won (max_speed 0.5; the first robot section dropped)
    f = tmp_path / "dup.yaml"
    f.write_text(text)
    msg = assert_user_error(*run(capsys, "config", "--config", f), str(f), repr(key))
    assert f"line {line}" in msg, msg


def test_a_duplicate_key_in_a_scenario_is_refused(tmp_path, tiny, capsys):
    f = tmp_path / "s.yaml"
    f.write_text(
        "pedestrians:\n  - start: [0.0, 3.0]\n    goal: [0.0, -3.0]\n    emotion: happy\n"
        "    emotion: negative\n"
    )
    msg = assert_user_error(*run(capsys, "sim", "--scenario", f, "--config", tiny), str(f))
    assert "'emotion'" in msg and "line 5" in msg, msg


def test_a_merge_key_is_not_a_duplicate(tmp_path):
    f = tmp_path / "c.yaml"
    f.write_text("_base: &b {max_speed: 0.3, radius: 0.25}\nrobot:\n  <<: *b\n  max_speed: 0.35\n")
    cfg = load_config(f)
    assert (cfg.robot.max_speed, cfg.robot.radius) == (0.35, 0.25)


def test_a_yaml_file_above_the_size_limit_is_refused_before_it_is_parsed(tmp_path, capsys):
    f = tmp_path / "big.yaml"
    f.write_text("robot: {max_speed: 0.3}\n" + "# padding\n" * (MAX_YAML_BYTES // 10 + 1))
    t0 = time.perf_counter()
    msg = assert_user_error(*run(capsys, "config", "--config", f), str(f), "bytes")
    assert time.perf_counter() - t0 < 1.0
    assert "1 MB" in msg, msg


def test_a_yaml_file_with_too_many_values_is_refused(tmp_path, capsys):
    # 200 000 numbers in 600 kB: under the byte limit, over the value limit
    f = tmp_path / "many.yaml"
    f.write_text("robot: {start: [" + ", ".join(["1"] * 200_000) + "]}\n")
    msg = assert_user_error(*run(capsys, "config", "--config", f), str(f))
    assert str(MAX_YAML_VALUES) in msg, msg


def test_a_long_emotion_schedule_is_refused_before_the_typed_load(tmp_path, tiny, capsys):
    # before: accepted (1 000 000 entries parsed for 63 s); now refused at MAX_SCHEDULE
    f = tmp_path / "s.yaml"
    schedule = ", ".join(["happy", "negative"] * (MAX_SCHEDULE // 2 + 1))
    f.write_text(
        "pedestrians:\n  - start: [0.0, 3.0]\n    goal: [0.0, -3.0]\n    emotion: happy\n"
        f"    emotion_schedule: [{schedule}]\n"
    )
    msg = assert_user_error(*run(capsys, "sim", "--scenario", f, "--config", tiny), str(f))
    assert "pedestrians[0].emotion_schedule" in msg and str(MAX_SCHEDULE) in msg, msg


def test_a_schedule_at_the_limit_loads(tmp_path):
    f = tmp_path / "s.yaml"
    schedule = ", ".join((["happy", "negative"] * MAX_SCHEDULE)[:MAX_SCHEDULE])
    f.write_text(
        "pedestrians:\n  - start: [0.0, 3.0]\n    goal: [0.0, -3.0]\n    emotion: happy\n"
        f"    emotion_schedule: [{schedule}]\n"
    )
    assert len(load_scenario(f).pedestrians[0].emotion_schedule) == MAX_SCHEDULE


@pytest.mark.parametrize(
    "text, argv, field",
    [
        (
            "robot: {start: [" + ", ".join(["1.0"] * 500) + "]}\n",
            ["config", "--config", "{f}"],
            "robot.start",
        ),
        (
            "confusion: [" + ", ".join(["[1, 0, 0]"] * 500) + "]\n",
            ["sim", "--emotion-estimate", "{f}", "--config", "{tiny}"],
            "confusion",
        ),
    ],
)
def test_any_list_is_capped_before_the_typed_load(tmp_path, tiny, capsys, text, argv, field):
    f = tmp_path / "c.yaml"
    f.write_text(text)
    args = [a.format(f=f, tiny=tiny) for a in argv]
    msg = assert_user_error(*run(capsys, *args), str(f), field)
    assert "500 given, at most" in msg, msg


# --- Message length ---------------------------------------------------------------------------


@pytest.mark.slow
def test_a_huge_value_is_cut_in_the_message(tmp_path, capsys):
    # before: robot.max_speed = [0, 0, … 50 000 times] echoed whole (150 kB on one line)
    f = tmp_path / "c.yaml"
    f.write_text("robot: {max_speed: [" + ", ".join(["0"] * 50_000) + "]}\n")
    msg = assert_user_error(*run(capsys, "config", "--config", f), str(f), "robot.max_speed")
    assert len(msg) < 400, msg


def test_every_message_is_cut_centrally(capsys):
    # a message of any origin (here a flag's own 3000-character value) is cut to about 500
    # characters, saying how much was cut
    code, err = run(capsys, "sim", "--scenario", "/".join(["d" * 200] * 15))
    line = assert_user_error(code, err, "--scenario")
    assert len(line) <= 600, len(line)
    assert "characters cut" in line, line


def test_a_long_string_value_is_cut_in_the_config_error(tmp_path):
    f = tmp_path / "c.yaml"
    f.write_text("robot: {max_speed: '" + "z" * 100_000 + "'}\n")
    with pytest.raises(ConfigError) as e:
        load_config(f)
    assert len(str(e.value)) < 400, len(str(e.value))


# --- Images: every format's declared size, before decoding -------------------------------------


def _encoded(ext: str, image: np.ndarray | None = None) -> bytearray:
    image = np.full((64, 64, 3), 128, np.uint8) if image is None else image
    ok, buf = cv2.imencode(ext, image)
    assert ok, ext
    return bytearray(buf.tobytes())


def _declaring(folder: Path, w: int, h: int) -> dict[str, Path]:
    """Tiny files of every format OpenCV decodes here, each declaring w x h pixels."""
    files: dict[str, bytes] = {}
    b = _encoded(".bmp")
    struct.pack_into("<ii", b, 18, w, h)
    files["bmp"] = b
    b = _encoded(".png")
    struct.pack_into(">II", b, 16, w, h)
    struct.pack_into(">I", b, 29, zlib.crc32(bytes(b[12:29])))
    files["png"] = b
    b = _encoded(".jpg")
    i = b.index(b"\xff\xc0")
    struct.pack_into(">HH", b, i + 5, h, w)
    files["jpg"] = b
    b = _encoded(".jp2")
    i = b.index(b"\xff\x51")  # SIZ: image and tile size
    struct.pack_into(">II", b, i + 6, w, h)
    struct.pack_into(">II", b, i + 22, w, h)
    j = b.index(b"ihdr")
    struct.pack_into(">II", b, j + 4, h, w)
    files["jp2"] = b
    b = _encoded(".gif")
    struct.pack_into("<HH", b, 6, w, h)
    i = b.index(b"\x2c", 13)
    struct.pack_into("<HH", b, i + 5, w, h)
    files["gif"] = b
    b = bytearray(cv2.imencode(".tiff", np.full((8, 8, 3), 9, np.uint8), [259, 1])[1].tobytes())
    e = "<" if b[:2] == b"II" else ">"
    off = struct.unpack_from(e + "I", b, 4)[0]
    for k in range(struct.unpack_from(e + "H", b, off)[0]):
        p = off + 2 + 12 * k
        tag, typ = struct.unpack_from(e + "HH", b, p)
        if tag in (256, 257):
            value = w if tag == 256 else h
            struct.pack_into(
                e + ("HH" if typ == 3 else "I"), b, p + 8, *((value, 0) if typ == 3 else (value,))
            )
    files["tiff"] = b
    files["ppm"] = f"P6\n{w} {h}\n255\n".encode() + bytes(192)
    files["pgm"] = f"P5\n# a comment\n{w}\n{h}\n255\n".encode() + bytes(64)
    files["pbm"] = f"P4\n{w} {h}\n".encode() + bytes(64)
    files["pam"] = (
        f"P7\nWIDTH {w}\nHEIGHT {h}\nDEPTH 3\nMAXVAL 255\nTUPLTYPE RGB\nENDHDR\n".encode()
        + bytes(192)
    )
    files["pfm"] = f"PF\n{w} {h}\n-1.0\n".encode() + bytes(768)
    files["ras"] = struct.pack(">8I", 0x59A66A95, w, h, 24, 0, 1, 0, 0) + bytes(192)
    files["hdr"] = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode() + bytes(256)
    files["pic"] = f"#?RGBE\nEXPOSURE=1.0\n\n+X {w} -Y {h}\n".encode() + bytes(256)
    paths = {}
    for ext, data in files.items():
        paths[ext] = folder / f"big.{ext}"
        paths[ext].write_bytes(bytes(data))
    return paths


@pytest.mark.slow
def test_a_huge_hdr_image_is_refused_from_its_header_in_bounded_memory(tmp_path):
    # before: image_header_size knew no HDR: 16500 x 16500 decoded to 4.3 GB (here the
    # 2 GB limit: a failed allocation, OpenCV's lines on stderr, "not a readable image")
    hdr = _declaring(tmp_path, BIG, BIG)["hdr"]
    code, out, err = _child(CLI_WITH_PEAK, "emotion", hdr, limit_gb=2.5)
    line = assert_user_error(code, err, str(hdr), f"{BIG}x{BIG} = 272 megapixels")
    assert err.strip() == line, err  # nothing else on stderr
    assert _peak_mb(out) < 1000, out


def test_the_header_size_is_known_for_formats_pillow_does_not_read(tmp_path):
    paths = _declaring(tmp_path, BIG, 12345)
    for ext in ("hdr", "pic", "pam", "pfm", "ppm", "pgm", "pbm"):
        assert image_header_size(paths[ext]) == (BIG, 12345), ext


def test_every_format_declaring_too_many_pixels_is_refused_before_decoding(tmp_path):
    # one child for all formats, 2.5 GB of address space: a decode of 272 MP would not fit
    paths = _declaring(tmp_path, BIG, BIG)
    code, out, err = _child(
        """
        import json
        from emonav_drake.perception.image_io import ImageReadError, load_image_limited
        result = {}
        for p in sys.argv[1:]:
            try:
                load_image_limited(p)
                result[p] = "decoded"
            except ImageReadError as e:
                result[p] = str(e)
        print(json.dumps(result))
        print("PEAK_MB", peak_mb())
        """,
        *paths.values(),
        limit_gb=2.5,
    )
    assert code == 0, err
    result = json.loads(out.splitlines()[0])
    for ext, p in paths.items():
        assert "megapixels" in result[str(p)] and "268" in result[str(p)], (ext, result[str(p)])
    assert err.strip() == "", err
    assert _peak_mb(out) < 600, out


def test_opencv_itself_refuses_an_oversized_image_whose_size_we_cannot_read(tmp_path):
    # the guard behind the header parsers: emonav_drake sets OPENCV_IO_MAX_IMAGE_PIXELS
    # before cv2 loads, so every OpenCV decoder refuses more than HARD_MAX_PIXELS
    bmp = _declaring(tmp_path, BIG, BIG)["bmp"]
    code, out, err = _child(
        """
        import emonav_drake, os
        from pathlib import Path
        from emonav_drake.perception import image_io
        print(os.environ["OPENCV_IO_MAX_IMAGE_PIXELS"])
        try:
            image_io._decode(Path(sys.argv[1]), image_io.cv2.IMREAD_COLOR)  # no header check
        except image_io.ImageReadError as e:
            print(e)
        """,
        bmp,
    )
    assert code == 0, err
    limit, message = out.splitlines()[:2]
    assert int(limit) == HARD_MAX_PIXELS
    assert str(bmp) in message and "268 megapixels" in message, message
    assert err.strip() == "", err


def test_a_video_with_huge_frames_is_refused_before_the_first_frame(tmp_path):
    # the frame size of a video is checked once it is opened (OpenCV's image limit does
    # not apply to videos): here a real small video, the limit lowered in the child
    video = tmp_path / "v.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 5, (64, 48))
    for i in range(3):
        writer.write(np.full((48, 64, 3), 40 * i, np.uint8))
    writer.release()
    code, out, err = _child(
        """
        from emonav_drake.perception import image_io
        image_io.HARD_MAX_PIXELS = 1000
        try:
            next(image_io.video_frames(sys.argv[1]))
        except image_io.ImageReadError as e:
            print(e)
        """,
        video,
    )
    assert code == 0, err
    assert "64x48" in out and "megapixels" in out, out


# --- Damaged images and videos: only our line on stderr ---------------------------------------


def _damaged_png(path: Path) -> Path:
    b = _encoded(".png", (np.random.default_rng(0).random((64, 64, 3)) * 255).astype(np.uint8))
    b[100] ^= 0xFF  # inside IDAT: libpng reports a CRC error on stderr by itself
    path.write_bytes(bytes(b))
    return path


def _damaged_mp4(path: Path, tmp: Path) -> Path:
    good = tmp / "good.mp4"
    w = cv2.VideoWriter(str(good), cv2.VideoWriter_fourcc(*"mp4v"), 10, (64, 64))
    frame = (np.random.default_rng(1).random((64, 64, 3)) * 255).astype(np.uint8)
    for i in range(20):
        w.write(np.roll(frame, i, 0))
    w.release()
    b = good.read_bytes()
    b = b[: len(b) // 3]  # the index (moov) comes last: ffmpeg says it is missing
    path.write_bytes(bytes(b))
    return path


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["png", "mp4"])
def test_a_damaged_image_or_video_gives_only_our_line(tmp_path, kind):
    # before: "libpng error: IDAT: CRC error" / "[mov,mp4,… @ 0x…] error reading header"
    # printed by the C libraries before our line
    path = (
        _damaged_png(tmp_path / "damaged.png")
        if kind == "png"
        else _damaged_mp4(tmp_path / "damaged.mp4", tmp_path)
    )
    p = subprocess.run(
        [sys.executable, "-m", "emonav_drake.cli", "emotion", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    line = assert_user_error(p.returncode, p.stderr, str(path))
    assert p.stderr.strip() == line, p.stderr


@pytest.mark.slow
def test_a_damaged_jpeg_is_classified_with_our_warning(tmp_path):
    # libjpeg decodes what it can of a JPEG with damaged bits and says "Corrupt JPEG data"
    # on stderr by itself; now our warning says it instead of the library's line
    img = (np.random.default_rng(2).random((256, 256, 3)) * 255).astype(np.uint8)
    data = _encoded(".jpg", img)
    for k in range(len(data) // 2, len(data) // 2 + 40, 5):
        data[k] ^= 0x10
    path = tmp_path / "flipped.jpg"
    path.write_bytes(bytes(data))
    p = subprocess.run(
        [sys.executable, "-m", "emonav_drake.cli", "emotion", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 0, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and "damaged" in lines[0], p.stderr
    assert "Corrupt JPEG data" in lines[0], p.stderr  # what the decoder said, in our line


# --- Workers ------------------------------------------------------------------------------------


def _forbid_ray(monkeypatch):
    from emonav_drake import parallel

    def called(*_a, **_k):
        raise AssertionError("Ray started although --workers was refused")

    monkeypatch.setattr(parallel, "init_ray", called)


@pytest.mark.parametrize(
    "argv",
    [
        ["benchmark", "--planners", "dwa", "--trials", "1", "--workers", "{w}", "--out", "{tmp}/b"],
        ["calibrate", "collect", "--episodes", "1", "--workers", "{w}", "--out", "{tmp}/t.jsonl"],
        ["digit-rounds", "--from", "{tmp}/none", "--workers", "{w}", "--out", "{tmp}/d"],
    ],
)
def test_workers_beyond_a_multiple_of_the_cores_are_refused(tmp_path, capsys, monkeypatch, argv):
    # before: --workers 100000 started a local Ray with 100 000 CPUs (8 actors, 3.5 GB on 2
    # cores for the benchmark)
    from emonav_drake.parallel import max_local_workers

    _forbid_ray(monkeypatch)
    args = [a.format(w=100_000, tmp=tmp_path) for a in argv]
    msg = assert_user_error(*run(capsys, *args), "--workers 100000")
    assert str(max_local_workers()) in msg, msg


def test_the_worker_cap_is_four_per_core_and_not_on_a_cluster():
    from emonav_drake.parallel import check_workers, max_local_workers

    assert max_local_workers() == 4 * (os.cpu_count() or 1)
    check_workers(max_local_workers(), None)
    check_workers(100_000, "auto")  # a cluster: its CPUs decide
    with pytest.raises(ConfigError, match="--workers"):
        check_workers(max_local_workers() + 1, None)
    with pytest.raises(ConfigError, match="--workers 0"):
        check_workers(0, "auto")


# --- Ranges: every numeric field has one ------------------------------------------------------


@pytest.mark.parametrize(
    "text, field",
    [
        ("dwa: {goal_weight: -1.0}\n", "dwa.goal_weight"),
        ("dwa: {clearance_weight: 1.0e308}\n", "dwa.clearance_weight"),
        ("dwa: {discomfort_weight: -3.0}\n", "dwa.discomfort_weight"),
        ("dwa: {speed_weight: 1.0e300}\n", "dwa.speed_weight"),
        ("reward: {goal: 1.0e308}\n", "reward.goal"),
        ("reward: {collision: -1.0e308}\n", "reward.collision"),
        ("reward: {discomfort: 1.0e200}\n", "reward.discomfort"),
        ("reward: {progress_gain: 1.0e308}\n", "reward.progress_gain"),
    ],
)
def test_dwa_weights_and_rewards_are_bounded(tmp_path, capsys, text, field):
    # before: accepted; reward.goal 1e308 gave total_reward null
    f = tmp_path / "c.yaml"
    f.write_text(text)
    assert_user_error(*run(capsys, "config", "--config", f), str(f), field, "out of range")


def test_a_scenarios_emotion_period_has_the_configs_range(tmp_path, tiny, capsys):
    # before: 1e-300 accepted (the config's range is [0.1, 100])
    lo, hi = field_range(EmoNavConfig, "crowd.emotion_change_period")
    f = tmp_path / "s.yaml"
    for bad in ("1.0e-300", "0.05", "1000.0"):
        f.write_text(f"emotion_change_period: {bad}\n")
        msg = assert_user_error(
            *run(capsys, "sim", "--scenario", f, "--config", tiny), str(f), "emotion_change_period"
        )
        assert f"[{lo}, {hi}]" in msg, msg


def test_an_emotion_estimate_seed_beyond_64_bits_is_refused(tmp_path, tiny, capsys):
    f = tmp_path / "e.yaml"
    f.write_text(f"mode: confusion\nseed: {2**70}\n")
    assert_user_error(
        *run(capsys, "sim", "--emotion-estimate", f, "--config", tiny), str(f), "seed"
    )
    with pytest.raises(ConfigError, match="seed"):
        EmotionEstimateParams(seed=2**64).validate()
    EmotionEstimateParams(seed=2**64 - 1).validate()


def _numeric(kind: typing.Any) -> bool:
    """int, float or (nested) lists of them; bool is not numeric."""
    if kind in (int, float):
        return True
    if typing.get_origin(kind) in (typing.Union, types.UnionType):  # float | None
        return any(_numeric(k) for k in typing.get_args(kind) if k is not type(None))
    if typing.get_origin(kind) is list:
        return _numeric(typing.get_args(kind)[0])
    return False


def field_problems(schema: type, prefix: str = "") -> list[str]:
    """What is wrong with the metadata of `schema`'s fields (nested dataclasses included):
    a field without a doc, a numeric field without a finite two-sided range, or a range on
    a field of no number."""
    problems = []
    for f in dc.fields(schema):
        name, bounds = prefix + f.name, f.metadata.get("range")
        if not f.metadata.get("doc"):
            problems.append(f"{name}: no doc")
        if dc.is_dataclass(f.type):
            problems += field_problems(f.type, f"{name}.")
        elif _numeric(f.type):
            lo, hi = (None, None) if bounds is None else bounds[-2:]
            if lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)):
                problems.append(f"{name}: no finite two-sided range ({bounds!r})")
            elif not lo <= hi:
                problems.append(f"{name}: range {bounds!r} is empty")
        elif bounds is not None:
            problems.append(f"{name}: a range on a field of no number ({bounds!r})")
    return problems


def _list_item_schemas(schema: type) -> dict[str, type]:
    """List fields of dataclass items (`Scenario.pedestrians` → PedestrianSpec)."""
    out = {}
    for f in dc.fields(schema):
        if typing.get_origin(f.type) is list and dc.is_dataclass(typing.get_args(f.type)[0]):
            out[f.name] = typing.get_args(f.type)[0]
    return out


@pytest.mark.parametrize(
    "schema",
    [
        EmoNavConfig,
        Scenario,
        PedestrianSpec,
        StaticDiscSpec,
        WallSpec,
        EmotionEstimateParams,
        *EXPERT_SPECS,
    ],
    ids=lambda schema: schema.__name__,
)
def test_every_numeric_field_has_a_range(schema):
    # a new numeric field without a range in its `setting(...)` fails here, and a new field
    # without a doc
    problems = field_problems(schema)
    assert not problems, f"{schema.__name__}: {problems}"


def test_the_scenario_and_the_estimate_use_the_configs_ranges():
    def rng(schema, name):
        return field_range(schema, name)

    assert rng(Scenario, "emotion_change_period") == rng(
        EmoNavConfig, "crowd.emotion_change_period"
    )
    assert rng(Scenario, "robot_start") == rng(EmoNavConfig, "robot.start") == WORLD_POINT
    assert rng(Scenario, "robot_goal") == rng(EmoNavConfig, "robot.goal") == WORLD_POINT
    assert rng(PedestrianSpec, "start") == rng(PedestrianSpec, "goal") == WORLD_POINT
    assert rng(PedestrianSpec, "waypoints") == (None, *WORLD_POINT[1:])
    assert rng(StaticDiscSpec, "center") == rng(WallSpec, "start") == WORLD_POINT
    assert rng(WallSpec, "end") == WORLD_POINT
    assert rng(Scenario, "seed") == (-1, 2**64 - 1)
    assert rng(EmotionEstimateParams, "seed") == SEED_RANGE == (0, 2**64 - 1)
    assert set(_list_item_schemas(Scenario)) == {"pedestrians", "obstacles", "walls"}
    assert dc.is_dataclass(HeadCameraParams)


def test_the_largest_reward_keeps_the_total_reward_finite():
    # every step's reward is at most |collision| + |discomfort| + goal + progress_gain x the
    # farthest a step can move, over the longest episode
    def r(name):
        return field_range(EmoNavConfig, name)

    worst_step = (
        max(abs(v) for v in r("reward.collision"))
        + max(abs(v) for v in r("reward.discomfort"))
        + max(abs(v) for v in r("reward.goal"))
        + r("reward.progress_gain")[1] * r("robot.max_speed")[1] * r("robot.step_time")[1]
    )
    assert math.isfinite(worst_step * r("episode.max_steps")[1])
    assert worst_step * r("episode.max_steps")[1] < 1e12


def test_every_shipped_configuration_and_scenario_still_loads():
    from emonav_drake.configs import SETTINGS, load_setting
    from emonav_drake.learning.config import DaggerConfig, SarlConfig
    from emonav_drake.learning.sac_config import FinetuneConfig
    from emonav_drake.planners.variants import VARIANTS
    from emonav_drake.scenarios import EXAMPLES, scenario_path
    from emonav_drake.typed_yaml import load_typed_yaml

    for name in SETTINGS:
        load_setting(name)
    load_config(PACKAGE / "configs" / "walking_1ms.yaml")
    load_config(PACKAGE / "configs" / "walking_4ms.yaml")
    load_typed_yaml(FinetuneConfig, path=PACKAGE / "configs" / "finetune_digit.yaml").validate()
    load_typed_yaml(SarlConfig, path=PACKAGE / "configs" / "rgl.yaml").validate()
    for v in VARIANTS.values():
        load_typed_yaml(DaggerConfig, path=v.config).validate()
    for name in EXAMPLES:
        load_scenario(scenario_path(name))
    shipped = {p.name for p in (PACKAGE / "configs").glob("*.yaml")}
    assert shipped == {f"{s}.yaml" for s in SETTINGS} | {
        "walking_1ms.yaml",
        "walking_4ms.yaml",
        "finetune_digit.yaml",
        "rgl.yaml",
    }
