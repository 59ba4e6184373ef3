"""Robot recordings against panoloc: the rendered sequence's frames written as
ROS 1 bags, ROS 2 bags (sqlite3 and MCAP storage) and MCAP files, in each
image encoding read, give the rows panoloc writes for the same frames as an
image folder; the poses written back as ROS messages equal the CSV's."""
import json
import math
import shutil
import sys

import numpy as np
import pytest

import panotrack as pt
from conftest import program, run

rosbags = pytest.importorskip("rosbags", reason="reading recordings needs rosbags (scripts/install-deps.sh)")
pytest.importorskip("mcap", reason="writing and reading MCAP needs mcap (scripts/install-deps.sh)")
mcap_ros2 = pytest.importorskip("mcap_ros2", reason="decoding MCAP needs mcap-ros2-support (scripts/install-deps.sh)")
cv2 = pytest.importorskip("cv2", reason="colour and compressed images need OpenCV's cv2 (scripts/install-deps.sh)")

from panotrack import bag  # noqa: E402

TOPIC = "/camera/image"
STEP_NS = 100_000_000  # 10 frames/s: panoloc's times for an image folder


def csv_text(rows):
    return "\n".join([bag.POSE_CSV_HEADER] + [bag.format_pose_row(r) for r in rows]) + "\n"


def panoloc_folder(folder, out, seq, *args):
    """panoloc on an image folder (init from the sequence's case.yaml); its CSV's text."""
    r = run([program("panoloc"), str(folder), "--calib", str(seq / "calib.yaml"), "--map", str(seq / "map.yaml"),
             "-o", str(out), "-q", "--init", init_arg(seq), *args])
    assert r.returncode == 0, r.stderr
    return out.read_text()


def case_init(seq):
    from ruamel.yaml import YAML
    p = YAML(typ="safe", pure=True).load((seq / "case.yaml").read_text())["initial_pose"]
    return float(p["x"]), float(p["y"]), float(p["theta"])


def init_arg(seq):
    """The case's initial pose as panoloc's --init (exactly the same doubles)."""
    return ",".join(repr(v) for v in case_init(seq))


def read_csv_text(text):
    """A pose CSV's text as a POSE_DTYPE array (empty fields NaN)."""
    lines = text.splitlines()
    assert lines[0] == bag.POSE_CSV_HEADER
    names = pt.POSE_DTYPE.names
    return np.array([tuple(v if k == "status" else (float(v) if v else math.nan) for k, v in zip(names, line.split(",")))
                     for line in lines[1:]], dtype=pt.POSE_DTYPE)


@pytest.fixture(scope="module")
def grey(sequence):
    """The sequence's frames as panoloc reads them (66 x 500 x 500 uint8)."""
    return [f for f, _ in pt.FrameReader(sequence / "frames")]


def tint(g):
    """A colour frame whose channels differ (BGR), from a grey one."""
    g = g.astype(np.int32)
    return np.clip(np.dstack([g * 0.8 + 20, g, g * 1.15 - 10]), 0, 255).astype(np.uint8)


@pytest.fixture(scope="module")
def references(sequence, grey, tmp_path_factory):
    """panoloc's CSV text for the grey PNG frames, the tinted colour PNG
    frames and JPEG frames (quality 90) of the same pictures."""
    root = tmp_path_factory.mktemp("ref")
    texts = {}
    for name, frames, ext, params in [("grey", grey, ".png", []), ("colour", [tint(g) for g in grey], ".png", []),
                                      ("jpeg", grey, ".jpg", [cv2.IMWRITE_JPEG_QUALITY, 90])]:
        folder = root / name
        folder.mkdir()
        for i, f in enumerate(frames):
            assert cv2.imwrite(str(folder / f"frame_{i:04d}{ext}"), f, params)
        texts[name] = panoloc_folder(folder, root / f"{name}.csv", sequence)
    return texts


# (file name, encoding, ROS 2 storage, frames, panoloc reference)
CASES = [
    ("ros1.bag", "mono8", None, "grey", "grey"),
    ("ros2_sqlite3", "bgr8", "sqlite3", "colour", "colour"),
    ("ros2_mcap", "rgb8", "mcap", "colour", "colour"),
    ("plain.mcap", "png", None, "grey", "grey"),
    ("plain_colour.mcap", "png", None, "colour", "colour"),
    ("ros1_16.bag", "mono16", None, "grey", "grey"),
    ("ros2_jpeg", "jpeg", "sqlite3", "grey", "jpeg"),
]


@pytest.mark.parametrize("name,encoding,storage,frames,reference", CASES, ids=[c[0] for c in CASES])
def test_localize_bag_equals_panoloc(sequence, grey, references, tmp_path, name, encoding, storage, frames,
                                     reference):
    # Lossless frames give panoloc's CSV byte for byte, JPEG frames too
    # (panoloc reading the same JPEG files: the same decoder); the times are
    # the header stamps.
    pictures = grey if frames == "grey" else [tint(g) for g in grey]
    stamps = [i * STEP_NS for i in range(len(grey))]
    path = tmp_path / name
    assert bag.write_image_bag(path, pictures, stamps, topic=TOPIC, encoding=encoding,
                               storage=storage or "sqlite3", jpeg_quality=90) == 66
    rows, summary = pt.localize_bag(path, TOPIC, sequence / "calib.yaml", sequence / "map.yaml",
                                    init=case_init(sequence), return_summary=True)
    assert rows.dtype == pt.POSE_DTYPE
    assert csv_text(rows) == references[reference]
    assert summary["end"] == "done" and summary["frames"] == 66 and summary["n_ok"] == 66
    assert summary["topic"] == TOPIC
    assert summary["stamp_ns"].tolist() == stamps
    np.testing.assert_array_equal(rows["time_s"], np.arange(66) / 10)
    assert summary["covariance"].shape == (66, 3, 3)


def test_jpeg_accuracy_against_lossless(references):
    # JPEG at quality 90 against the lossless frames, measured: at most
    # 0.0214 units in x, 0.0186 in y and 0.000146 rad in theta, about the
    # README's accuracy of this sequence (0.018 units rms) and far under its
    # landmarks' distance (about 70 units); the bounds allow twice that.
    def parse(text):
        lines = text.splitlines()[1:]
        return np.array([[float(v) for v in line.split(",")[2:5]] for line in lines])
    lossless, jpeg = parse(references["grey"]), parse(references["jpeg"])
    d = np.abs(jpeg - lossless)
    assert d[:, :2].max() < 0.04 and d[:, 2].max() < 3e-4, d.max(axis=0)


def test_times_from_header_stamps_and_case_file(sequence, grey, references, tmp_path):
    # Epoch stamps (not the recording times, which are set 5 s later), the
    # first pose from the case.yaml beside the recording (panoloc's rule).
    folder = tmp_path / "run"
    folder.mkdir()
    shutil.copy(sequence / "case.yaml", folder / "case.yaml")
    t0 = 1_700_000_000_123_456_789
    stamps = [t0 + i * STEP_NS for i in range(len(grey))]
    path = folder / "epoch.bag"
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore
    ts = get_typestore(Stores.ROS1_NOETIC)
    T = ts.types
    with Writer(path) as w:
        conn = w.add_connection(TOPIC, bag.IMAGE_TYPE, typestore=ts)
        for f, ns in zip(grey, stamps):
            stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            msg = T[bag.IMAGE_TYPE](header=T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="cam"),
                                    height=500, width=500, encoding="mono8", is_bigendian=0, step=500,
                                    data=f.reshape(-1))
            w.write(conn, ns + 5 * 10**9, ts.serialize_ros1(msg, bag.IMAGE_TYPE))
    rows, summary = pt.localize_bag(path, TOPIC, sequence / "calib.yaml", sequence / "map.yaml",
                                    return_summary=True)
    assert summary["stamp_ns"].tolist() == stamps
    np.testing.assert_array_equal(rows["time_s"], [float("%.6f" % (ns / 10**9)) for ns in stamps])
    # The localiser sees the times since the first frame: the rows are
    # panoloc's but for the times.
    expected = read_csv_text(references["grey"])
    for name in pt.POSE_DTYPE.names:
        if name != "time_s":
            np.testing.assert_array_equal(rows[name], expected[name], err_msg=name)


def read_mcap(path):
    """{topic: [(log_time, decoded message)]} read with the mcap library."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    out = {}
    with open(path, "rb") as f:
        for schema, channel, message, decoded in make_reader(f, decoder_factories=[DecoderFactory()]) \
                .iter_decoded_messages():
            out.setdefault(channel.topic, []).append((message.log_time, schema.name, decoded))
    return out


def test_command_writes_csv_tum_and_mcap(sequence, grey, references, tmp_path):
    # The CSV and TUM files equal panoloc's byte for byte; the MCAP's poses
    # and covariances are the CSV's, in metres; outputs are refused when they
    # exist (without --force) or are the input.
    stamps = [i * STEP_NS for i in range(len(grey))]
    path = tmp_path / "run.bag"
    bag.write_image_bag(path, grey, stamps, topic=TOPIC, encoding="mono8")
    out = tmp_path / "poses.csv"
    argv = [sys.executable, "-m", "panotrack.bag_cli", "localize", str(path), "--topic", TOPIC,
            "--calib", str(sequence / "calib.yaml"), "--map", str(sequence / "map.yaml"), "-o", str(out),
            "--tum", str(tmp_path / "poses.tum"), "--mcap", "--summary-json", str(tmp_path / "summary.json"),
            "--init", init_arg(sequence)]
    r = run(argv)
    assert r.returncode == 0, r.stderr
    assert out.read_text() == references["grey"]
    ref_tum = tmp_path / "ref.tum"
    r2 = run([program("panoloc"), str(sequence / "frames"), "--calib", str(sequence / "calib.yaml"), "--map",
              str(sequence / "map.yaml"), "-o", str(tmp_path / "ref.csv"), "--tum", str(ref_tum), "-q",
              "--init", init_arg(sequence)])
    assert r2.returncode == 0, r2.stderr
    assert (tmp_path / "poses.tum").read_text() == ref_tum.read_text()
    summary = json.loads((tmp_path / "summary.json").read_text())
    s = summary["inputs"][0]
    assert summary["tool"] == "panotrack-bag"
    assert (s["end"], s["frames"], s["ok"], s["lost"], s["topic"]) == ("done", 66, 66, 0, TOPIC)
    mcap_path = tmp_path / "run.poses.mcap"
    assert s["outputs"] == {"poses": str(out), "tum": str(tmp_path / "poses.tum"), "mcap": str(mcap_path)}
    assert not list(tmp_path.glob("*.partial"))

    # The MCAP read back: one pose and one transform per ok frame, at its stamp.
    csv_rows = read_csv_text(out.read_text())
    m = pt.read_map(sequence / "map.yaml")
    mpu = 1.0 / m.units_per_metre()
    msgs = read_mcap(mcap_path)
    poses, tfs = msgs["/panotrack/pose"], msgs["/tf"]
    assert len(poses) == len(tfs) == 66
    assert [t for t, _, _ in poses] == stamps and [t for t, _, _ in tfs] == stamps
    assert {name for _, name, _ in poses} == {"geometry_msgs/msg/PoseWithCovarianceStamped"}
    for (t, _, p), (_, _, tf), row in zip(poses, tfs, csv_rows):
        assert p.header.frame_id == "map" and p.header.stamp.sec * 10**9 + p.header.stamp.nanosec == t
        pos, q = p.pose.pose.position, p.pose.pose.orientation
        assert (pos.x, pos.y, pos.z) == (row["x"] * mpu, row["y"] * mpu, 0.0)
        assert math.atan2(2 * q.w * q.z, 1 - 2 * q.z * q.z) == pytest.approx(row["theta_rad"], abs=1e-12)
        assert (q.x, q.y) == (0.0, 0.0)
        cov = np.array(p.pose.covariance).reshape(6, 6)
        np.testing.assert_array_equal(cov, cov.T)
        # z, roll, pitch: none (a planar pose).
        assert not cov[2:5, :].any() and not cov[:, 2:5].any()
        stds = np.sqrt(np.diag(cov)[[0, 1, 5]]) / [mpu, mpu, 1.0]
        np.testing.assert_allclose(stds, [row["std_x"], row["std_y"], row["std_theta"]], rtol=5e-6)
        (trans,) = tf.transforms
        assert (trans.header.frame_id, trans.child_frame_id) == ("map", "base_link")
        assert (trans.transform.translation.x, trans.transform.translation.y) == (pos.x, pos.y)
        r = trans.transform.rotation
        assert (r.x, r.y, r.z, r.w) == (q.x, q.y, q.z, q.w)

    # Existing outputs: refused without --force (nothing written), replaced with it.
    r = run(argv)
    assert r.returncode == 1
    assert r.stderr.strip() == f"panotrack-bag: {out}: exists (use --force, or force=True, to replace it)"
    r = run(argv + ["--force", "-q"])
    assert r.returncode == 0, r.stderr
    assert out.read_text() == references["grey"]
    # The input is never an output.
    r = run(argv[:argv.index("-o") + 1] + [str(path), "--force"])
    assert r.returncode == 1
    assert r.stderr.strip() == f"panotrack-bag: {path}: the poses would overwrite the input {path}"
    r = run([sys.executable, "-m", "panotrack.bag_cli", "info", str(path)])
    assert r.returncode == 0 and r.stdout.split() == [TOPIC, bag.IMAGE_TYPE, "66", "messages", "(image)"]


def write_one_image(path, encoding, data, width=500, height=500, step=500, msgtype=None):
    """A ROS 1 bag with one image message of the given fields."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore
    ts = get_typestore(Stores.ROS1_NOETIC)
    T = ts.types
    header = T["std_msgs/msg/Header"](seq=0, stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0),
                                      frame_id="cam")
    if msgtype == bag.COMPRESSED_TYPE:
        msg = T[msgtype](header=header, format=encoding, data=data)
    else:
        msgtype = bag.IMAGE_TYPE
        msg = T[msgtype](header=header, height=height, width=width, encoding=encoding, is_bigendian=0, step=step,
                         data=data)
    with Writer(path) as w:
        conn = w.add_connection(TOPIC, msgtype, typestore=ts)
        w.write(conn, 10**9, ts.serialize_ros1(msg, msgtype))
        other = w.add_connection("/odom", "std_msgs/msg/String", typestore=ts)
        w.write(other, 10**9, ts.serialize_ros1(T["std_msgs/msg/String"](data="x"), "std_msgs/msg/String"))


def bad(sequence, path, topic=TOPIC):
    with pytest.raises(pt.Error) as e:
        pt.localize_bag(path, topic, sequence / "calib.yaml", sequence / "map.yaml")
    message = str(e.value)
    assert "\n" not in message
    return message


def test_bad_recordings_give_one_line(sequence, grey, tmp_path):
    p = tmp_path / "one.bag"
    write_one_image(p, "mono8", grey[0].reshape(-1))
    assert bad(sequence, p, "/camera/missing") == f"{p}: no topic '/camera/missing' (image topics: {TOPIC})"
    assert bad(sequence, p, "/odom") == \
        f"{p}: topic '/odom' holds std_msgs/msg/String, not sensor_msgs/Image or sensor_msgs/CompressedImage"
    # The only image topic is taken when none is named.
    frames = bag.BagFrames(p)
    assert (frames.topic, frames.msgtype, frames.count) == (TOPIC, bag.IMAGE_TYPE, 1)
    frames.close()
    # A topic named without its leading slash is found.
    rows = pt.localize_bag(p, TOPIC[1:], sequence / "calib.yaml", sequence / "map.yaml", init=case_init(sequence))
    assert len(rows) == 1 and rows["time_s"][0] == 1.0

    p = tmp_path / "yuv.bag"
    write_one_image(p, "yuv422", np.zeros(500 * 500 * 2, np.uint8), step=1000)
    assert bad(sequence, p) == (f"{p}: message 0: image encoding 'yuv422' is not read (expected one of mono8, "
                                "rgb8, bgr8, rgba8, bgra8, mono16, rgb16, bgr16, 8UC1, 8UC3, 16UC1)")
    p = tmp_path / "short.bag"
    write_one_image(p, "mono8", np.zeros(1000, np.uint8))
    assert bad(sequence, p) == \
        f"{p}: message 0: 1000 bytes of data for a 500x500 mono8 image with rows of 500 bytes"
    p = tmp_path / "small.bag"
    write_one_image(p, "mono8", np.zeros(320 * 240, np.uint8), width=320, height=240, step=320)
    assert bad(sequence, p) == f"{p}: frame size 320x240 does not match the calibration's 500x500"
    p = tmp_path / "gif.bag"
    write_one_image(p, "gif", np.zeros(10, np.uint8), msgtype=bag.COMPRESSED_TYPE)
    assert bad(sequence, p) == f"{p}: message 0: compressed image format 'gif' is not read (expected jpeg or png)"
    p = tmp_path / "broken_jpeg.bag"
    write_one_image(p, "jpeg", np.arange(64, dtype=np.uint8), msgtype=bag.COMPRESSED_TYPE)
    assert bad(sequence, p) == f"{p}: message 0: cannot decode the JPEG data (64 bytes)"

    assert bad(sequence, tmp_path / "none.bag") == f"{tmp_path / 'none.bag'}: cannot open: No such file or directory"
    (tmp_path / "empty.mcap").write_bytes(b"")
    assert bad(sequence, tmp_path / "empty.mcap") == \
        f"{tmp_path / 'empty.mcap'}: truncated or damaged: expected a MCAP file, the first bytes show an empty file"
    (tmp_path / "clip.mp4").write_bytes(b"\0\0\0\x18ftypmp42")
    assert bad(sequence, tmp_path / "clip.mp4").startswith(f"{tmp_path / 'clip.mp4'}: not a recording panotrack reads")


def cut(path, fraction=0.5):
    """Cuts the recording's data file to `fraction` of its length (a
    recording interrupted by a crash)."""
    data_file = path if path.is_file() else next(f for f in path.iterdir() if f.suffix in (".db3", ".mcap"))
    data = data_file.read_bytes()
    data_file.write_bytes(data[:int(len(data) * fraction)])


# (recording, ROS 2 storage, messages whole before the cut at half its length)
TRUNCATED = [("t.bag", None, 4), ("t_mcap", "mcap", 5), ("t.mcap", None, 5)]


@pytest.mark.parametrize("name,storage,whole", TRUNCATED, ids=[c[0] for c in TRUNCATED])
def test_truncated_recording_ends_incomplete(sequence, references, tmp_path, name, storage, whole):
    # As panoloc for a truncated video: the frames before the damage are
    # tracked and their rows kept, the run ends incomplete with one line
    # naming the recording and the message where it breaks off; the command
    # writes the rows and exits 1.
    grey = [f for f, _ in pt.FrameReader(sequence / "frames")][:10]
    path = tmp_path / name
    bag.write_image_bag(path, grey, [i * STEP_NS for i in range(10)], topic=TOPIC, storage=storage or "sqlite3")
    cut(path)
    rows, summary = pt.localize_bag(path, TOPIC, sequence / "calib.yaml", sequence / "map.yaml",
                                    init=case_init(sequence), return_summary=True)
    assert summary["end"] == "incomplete" and summary["frames"] == whole
    assert summary["error"].startswith(f"truncated or damaged at message {whole} of {TOPIC} (")
    assert csv_text(rows) == "\n".join(references["grey"].splitlines()[:whole + 1]) + "\n"
    with pytest.warns(RuntimeWarning, match=f"localize_bag: incomplete: truncated or damaged at message {whole} "):
        pt.localize_bag(path, TOPIC, sequence / "calib.yaml", sequence / "map.yaml", init=case_init(sequence))

    out = tmp_path / "poses.csv"
    r = run([sys.executable, "-m", "panotrack.bag_cli", "localize", str(path), "--topic", TOPIC, "--calib",
             str(sequence / "calib.yaml"), "--map", str(sequence / "map.yaml"), "-o", str(out), "-q",
             "--summary-json", str(tmp_path / "summary.json"), "--init", init_arg(sequence)])
    assert r.returncode == 1
    (line,) = r.stderr.splitlines()
    assert line == f"panotrack-bag: {path}: incomplete: {summary['error']}"
    assert out.read_text() == csv_text(rows)
    s = json.loads((tmp_path / "summary.json").read_text())["inputs"][0]
    assert (s["end"], s["done"], s["frames"], s["error"]) == ("incomplete", False, whole, summary["error"])
    assert not list(tmp_path.glob("*.partial"))


def test_truncated_recording_before_its_images(sequence, grey, tmp_path):
    # Cut inside the MCAP file's first chunk, before the topic is known:
    # refused, naming the damage.
    path = tmp_path / "early.mcap"
    bag.write_image_bag(path, grey[:10], [i * STEP_NS for i in range(10)], topic=TOPIC)
    cut(path, 0.1)
    assert bad(sequence, path) == (f"{path}: truncated or damaged before any message of '{TOPIC}' (the file "
                                   f"ends inside a record at byte {path.stat().st_size})")
    # The ROS 1 bag's connection record comes whole before the first message:
    # the topic is known, and the run ends incomplete before its first frame.
    path = tmp_path / "early.bag"
    bag.write_image_bag(path, grey[:10], [i * STEP_NS for i in range(10)], topic=TOPIC)
    cut(path, 0.1)
    rows, summary = pt.localize_bag(path, TOPIC, sequence / "calib.yaml", sequence / "map.yaml",
                                    init=case_init(sequence), return_summary=True)
    assert len(rows) == 0 and (summary["end"], summary["frames"]) == ("incomplete", 0)
    assert summary["error"].startswith(f"truncated or damaged at message 0 of {TOPIC} (a record cut short at byte ")


def test_truncated_sqlite3_bag_is_refused(sequence, grey, tmp_path):
    # SQLite cannot open a database cut short: refused whole, one line.
    path = tmp_path / "t_sqlite3"
    bag.write_image_bag(path, grey[:10], [i * STEP_NS for i in range(10)], topic=TOPIC, storage="sqlite3")
    cut(path)
    assert bad(sequence, path) == (f"{path}: truncated or damaged (Cannot open database {path}/t_sqlite3.db3: "
                                   "database disk image is malformed)")


def test_unindexed_ros1_bag_ends_incomplete(sequence, grey, references, tmp_path):
    # A ROS 1 bag whose recorder died after its last chunk, before writing
    # the index: every message is read, and the run still ends incomplete
    # (what came after the last chunk is lost).
    path = tmp_path / "noindex.bag"
    bag.write_image_bag(path, grey[:6], [i * STEP_NS for i in range(6)], topic=TOPIC)
    data = bytearray(path.read_bytes())
    # The bag header's index_pos field, zeroed as rosbag leaves it until it closes the bag.
    at = data.index(b"index_pos=") + len(b"index_pos=")
    index_pos = int.from_bytes(data[at:at + 8], "little")
    data[at:at + 8] = bytes(8)
    path.write_bytes(bytes(data[:index_pos]))
    rows, summary = pt.localize_bag(path, TOPIC, sequence / "calib.yaml", sequence / "map.yaml",
                                    init=case_init(sequence), return_summary=True)
    assert summary["end"] == "incomplete" and summary["frames"] == 6
    assert summary["error"] == f"truncated or damaged at message 6 of {TOPIC} (the bag ends without its index)"
    assert csv_text(rows) == "\n".join(references["grey"].splitlines()[:7]) + "\n"


def test_ros1_mcap_equals_ros2_mcap(sequence, grey, references, tmp_path):
    # An MCAP file of ROS 1 messages (ros1 encoding, ros1msg schemas, as
    # Foxglove converts ROS 1 bags) gives the ROS 2 MCAP file's rows.
    stamps = [i * STEP_NS for i in range(len(grey))]
    results = {}
    for profile in ("ros1", "ros2"):
        path = tmp_path / f"{profile}.mcap"
        bag.write_image_bag(path, grey, stamps, topic=TOPIC, encoding="mono8", mcap_profile=profile)
        results[profile] = pt.localize_bag(path, TOPIC, sequence / "calib.yaml", sequence / "map.yaml",
                                           init=case_init(sequence), return_summary=True)
    from mcap.reader import make_reader
    with open(tmp_path / "ros1.mcap", "rb") as f:
        ((_, channel),) = make_reader(f).get_summary().channels.items()
    assert channel.message_encoding == "ros1"
    assert bag.bag_topics(tmp_path / "ros1.mcap") == {TOPIC: (bag.IMAGE_TYPE, 66)}
    (rows1, s1), (rows2, s2) = results["ros1"], results["ros2"]
    assert csv_text(rows1) == csv_text(rows2) == references["grey"]
    assert s1["stamp_ns"].tolist() == s2["stamp_ns"].tolist() == stamps
    np.testing.assert_array_equal(s1["covariance"], s2["covariance"])


def test_pose_mcap_refuses_inputs_and_existing(tmp_path):
    rows = np.zeros(1, dtype=pt.POSE_DTYPE)
    rows[0] = (0, 1.5, 1.0, 2.0, 0.5, "ok", 8, 0.01, 0.1, 0.2, 0.01, 0.7)
    cov = np.diag([0.01, 0.04, 1e-4])[None]
    out = tmp_path / "p.mcap"
    assert pt.write_pose_mcap(out, rows, cov, metres_per_unit=0.01) == 1
    with pytest.raises(pt.Error, match="exists"):
        pt.write_pose_mcap(out, rows, cov)
    with pytest.raises(pt.Error, match="would overwrite the input"):
        pt.write_pose_mcap(out, rows, cov, inputs=[out], force=True)
    ((t, _, p),) = read_mcap(out)["/panotrack/pose"]
    assert t == 1_500_000_000
    assert (p.pose.pose.position.x, p.pose.pose.position.y) == (0.01, 0.02)
    cov6 = np.array(p.pose.covariance).reshape(6, 6)
    np.testing.assert_allclose(cov6[np.ix_([0, 1, 5], [0, 1, 5])], np.diag([1e-6, 4e-6, 1e-4]), rtol=1e-12)


def test_frame_of_another_size_ends_the_run(sequence, grey, tmp_path):
    # As panoloc for a video: the rows before it are kept, the run is
    # incomplete (a warning without return_summary).
    frames = [grey[0], grey[1], np.zeros((240, 320), np.uint8), grey[2]]
    path = tmp_path / "sizes.mcap"
    bag.write_image_bag(path, frames, [i * STEP_NS for i in range(4)], topic=TOPIC)
    with pytest.warns(RuntimeWarning, match="localize_bag: incomplete: frame 2 is 320x240, the frames before it "
                                            "500x500"):
        rows = pt.localize_bag(path, TOPIC, sequence / "calib.yaml", sequence / "map.yaml", init=case_init(sequence))
    assert rows["frame"].tolist() == [0, 1] and (rows["status"] == "ok").all()
