"""Robot recordings: localisation straight from ROS 1 bags, ROS 2 bags
(sqlite3 or MCAP storage) and MCAP files, and the poses written back as ROS
messages in a new MCAP file.

The frames of one camera topic (sensor_msgs/Image or
sensor_msgs/CompressedImage) are converted to 8-bit grey as panoloc
converts the frames of an image folder (OpenCV's BGR to grey weights,
16-bit values by their high byte, as cv_bridge does) and tracked
one by one by panotrack.Localizer, the localiser panoloc runs: a recording
and an image folder of the same frames give the same rows.

Reading needs the Python packages rosbags (ROS 1 and ROS 2 bags; the
messages' deserialisers) and mcap (MCAP files of ROS 2 or ROS 1 messages)
and, for colour, 16-bit and CompressedImage topics, OpenCV's Python module
(cv2); writing needs mcap. A ROS 1 bag or an MCAP file cut short is read
up to the damage (the run then ends incomplete, as panoloc's for a
truncated video). No ROS installation is needed. Errors are
panotrack.Error with one line naming the recording and the reason.
"""

import math
import os
import pathlib
import queue
import re
import threading
import time

import numpy as np

from . import POSE_DTYPE, _panotrack
from ._panotrack import Error, Localizer

__all__ = ["localize_bag", "read_bag_frames", "BagFrames", "bag_topics", "write_pose_mcap", "write_image_bag",
           "format_pose_row", "round_pose_rows", "IMAGE_ENCODINGS"]

IMAGE_TYPE = "sensor_msgs/msg/Image"
COMPRESSED_TYPE = "sensor_msgs/msg/CompressedImage"

#: sensor_msgs/Image encodings read, with their channels and bytes per
#: channel ("8UC1" and the like are the same layouts without a colour order:
#: one channel is grey, three BGR, four BGRA, as OpenCV takes them).
IMAGE_ENCODINGS = {
    "mono8": (1, 1), "8uc1": (1, 1), "bgr8": (3, 1), "rgb8": (3, 1), "8uc3": (3, 1),
    "bgra8": (4, 1), "rgba8": (4, 1), "8uc4": (4, 1),
    "mono16": (1, 2), "16uc1": (1, 2), "bgr16": (3, 2), "rgb16": (3, 2), "16uc3": (3, 2),
    "bgra16": (4, 2), "rgba16": (4, 2), "16uc4": (4, 2),
}

# The first bytes of each kind of file.
_MAGIC = {b"#ROSBAG V2.0": "ROS 1 bag", b"\x89MCAP0\r\n": "MCAP file", b"SQLite format 3\x00": "ROS 2 sqlite3 bag"}

# Frames decoded ahead of the tracker (each a few hundred kB).
_PREFETCH = 16


def _fail(path, reason):
    raise Error(f"{os.fspath(path)}: {reason}")


def _import_rosbags(path):
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        _fail(path, "reading recordings needs the Python package rosbags (pip install rosbags)")
    return AnyReader, Stores, get_typestore


def _kind(path):
    """'ros1', 'ros2' (a bag folder or a .db3 file) or 'mcap', checked
    against the file's first bytes; raises Error for anything else."""
    p = pathlib.Path(path)
    if not p.exists():
        _fail(path, "cannot open: No such file or directory")
    if p.is_dir():
        if not (p / "metadata.yaml").exists():
            _fail(path, "not a ROS 2 bag folder (no metadata.yaml)")
        return "ros2"
    with open(p, "rb") as f:
        head = f.read(16)
    found = next((kind for magic, kind in _MAGIC.items() if head.startswith(magic)), None)
    expected = {".bag": "ROS 1 bag", ".mcap": "MCAP file", ".db3": "ROS 2 sqlite3 bag"}.get(p.suffix)
    if expected is None:
        _fail(path, "not a recording panotrack reads (expected a ROS 1 .bag, a ROS 2 bag folder or .db3 file, "
                    "or an .mcap file)")
    if found != expected:
        what = "an empty file" if not head else (f"a {found}" if found else "not one")
        _fail(path, f"truncated or damaged: expected a {expected}, the first bytes show {what}")
    return {"ROS 1 bag": "ros1", "MCAP file": "mcap", "ROS 2 sqlite3 bag": "ros2"}[expected]


def _reason(err):
    """One line from a reader's exception (its arguments, nested tuples
    flattened: rosbags passes on the messages of the errors it caught)."""
    def flat(args):
        for a in args:
            if isinstance(a, (tuple, list)):
                yield from flat(a)
            else:
                yield str(a)
    text = " ".join(" ".join(flat(err.args)).split())
    # A message quoted as a one-element tuple's repr: the message.
    text = re.sub(r"""\(['"](.*?)['"],\)""", r"\1", text)
    return text or type(err).__name__


class _Damaged(Error):
    """The recording breaks off (cut short, or damaged) after the messages
    read so far; the message is the reason, without the file."""


def _ros_type(name):
    """A schema's type name as rosbags names it (sensor_msgs/Image ->
    sensor_msgs/msg/Image)."""
    parts = name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else name


def _topic_table(connections, counts):
    """{topic: (message type, message count)} from (connection id, topic,
    message type) and the messages counted per connection id (a topic may
    have several connections)."""
    out = {}
    for cid, topic, msgtype in connections:
        out[topic] = (msgtype, out.get(topic, (msgtype, 0))[1] + counts.get(cid, 0))
    return out


class _McapFile:
    """An MCAP file read with the mcap library, ROS 2 (cdr) or ROS 1 (ros1)
    messages. A whole file is read through its summary; one without a
    readable footer or summary (cut short while recording) record by record
    up to the damage, which then ends the messages (_Damaged)."""

    def __init__(self, path):
        try:
            from mcap.reader import make_reader
        except ImportError:
            _fail(path, "reading MCAP files needs the Python package mcap (pip install mcap)")
        self.path = path
        self.damage = None
        self.schemas, self.channels, self.counts = {}, {}, {}
        self._summary = None
        try:
            with open(path, "rb") as f:
                summary = make_reader(f).get_summary()
            if summary is not None and summary.statistics is not None:
                self._summary = summary
                self.schemas, self.channels = dict(summary.schemas), dict(summary.channels)
                self.counts = dict(summary.statistics.channel_message_counts)
        except Exception:  # the footer or summary is missing or damaged
            self._summary = None
        if self._summary is None:
            for record in self._records(count_only=True):
                pass

    def _records(self, count_only=False):
        """(channel, message) in the file's order; the schemas and channels
        found on the way; sets self.damage where it breaks off."""
        from mcap import records
        from mcap.stream_reader import StreamReader
        ended = False
        with open(self.path, "rb") as f:
            try:
                for r in StreamReader(f, validate_crcs=True).records:
                    if isinstance(r, records.Schema):
                        self.schemas[r.id] = r
                    elif isinstance(r, records.Channel):
                        self.channels[r.id] = r
                    elif isinstance(r, records.Message):
                        if count_only:
                            self.counts[r.channel_id] = self.counts.get(r.channel_id, 0) + 1
                        else:
                            yield self.channels[r.channel_id], r
                    elif isinstance(r, records.Footer):
                        ended = True
            except Exception as e:
                from mcap.exceptions import EndOfFile
                what = "the file ends inside a record" if isinstance(e, EndOfFile) else _reason(e)
                self.damage = f"{what} at byte {f.tell()}"
                return
        if not ended:
            self.damage = "the file ends without its footer"

    def topics(self):
        def msgtype(ch):
            schema = self.schemas.get(ch.schema_id)
            return _ros_type(schema.name) if schema is not None else ""
        return _topic_table(((cid, ch.topic, msgtype(ch)) for cid, ch in self.channels.items()), self.counts)

    def messages(self, topic, msgtype):
        """(log_time, message) of the topic, deserialised with rosbags."""
        from rosbags.typesys import Stores, get_typestore
        stores = {}

        def decode(channel, data):
            encoding = channel.message_encoding
            if encoding not in stores:
                if encoding not in ("cdr", "ros1"):
                    _fail(self.path, f"topic '{topic}': message encoding '{encoding}' is not read "
                                     "(expected cdr or ros1)")
                store = get_typestore(Stores.ROS1_NOETIC if encoding == "ros1" else Stores.ROS2_HUMBLE)
                stores[encoding] = store
            store = stores[encoding]
            if encoding == "ros1":
                return store.deserialize_ros1(data, msgtype)
            return store.deserialize_cdr(data, msgtype)

        if self._summary is not None:
            from mcap.reader import make_reader
            with open(self.path, "rb") as f:
                try:
                    for _, channel, message in make_reader(f).iter_messages(topics=[topic], log_time_order=True):
                        yield message.log_time, decode(channel, message.data)
                except Error:
                    raise
                except Exception as e:
                    raise _Damaged(f"{_reason(e)}") from None
            return
        for channel, message in self._records():
            if channel.topic == topic:
                yield message.log_time, decode(channel, message.data)
        if self.damage is not None:
            raise _Damaged(self.damage)


class _Ros1File:
    """A ROS 1 bag without a readable index (cut short while recording),
    read record by record up to the damage."""

    _HEADER = b"#ROSBAG V2.0\n"

    def __init__(self, path):
        self.path = path
        self.damage = None
        self.connections, self.counts = {}, {}
        for _ in self._messages(count_only=True):
            pass

    @staticmethod
    def _fields(header):
        out, i = {}, 0
        while i + 4 <= len(header):
            n = int.from_bytes(header[i:i + 4], "little")
            name, _, value = header[i + 4:i + 4 + n].partition(b"=")
            out[name.decode()] = value
            i += 4 + n
        return out

    def _read_records(self, data, offset, where):
        """(fields, data, whole, data's offset) of the records in `data`
        from offset (`where`: data's offset in the file); a record whose
        data is cut short comes with what there is of it (whole False), one
        whose header is cut raises ValueError."""
        while offset < len(data):
            cut = ValueError(f"a record cut short at byte {where + offset}")
            if offset + 4 > len(data):
                raise cut
            hlen = int.from_bytes(data[offset:offset + 4], "little")
            end_header = offset + 4 + hlen
            if end_header + 4 > len(data):
                raise cut
            fields = self._fields(data[offset + 4:end_header])
            dlen = int.from_bytes(data[end_header:end_header + 4], "little")
            end = end_header + 4 + dlen
            yield fields, data[end_header + 4:end], end <= len(data), where + end_header + 4
            if end > len(data):
                raise cut
            offset = end

    def _messages(self, count_only=False):
        import bz2
        with open(self.path, "rb") as f:
            data = f.read()
        indexed = False
        try:
            for fields, body, whole, at in self._read_records(data, len(self._HEADER), 0):
                op = fields.get("op", b"\0")[0]
                if op == 0x03:  # bag header
                    index_pos = int.from_bytes(fields.get("index_pos", b"\0" * 8), "little")
                    indexed = 0 < index_pos < len(data)
                elif op == 0x05:  # chunk; an uncompressed one cut short gives its whole records
                    compression = fields.get("compression", b"none").decode()
                    if not whole and compression != "none":
                        continue
                    if compression == "bz2":
                        body = bz2.decompress(body)
                    elif compression == "lz4":
                        from lz4.frame import decompress
                        body = decompress(body)
                    elif compression != "none":
                        raise ValueError(f"chunk compression '{compression}' is not read")
                    for inner, payload, inner_whole, _ in self._read_records(body, 0, at if compression == "none" else 0):
                        if inner_whole:
                            yield from self._record(inner, payload, count_only)
                elif whole:
                    yield from self._record(fields, body, count_only)
        except Exception as e:
            self.damage = _reason(e)
            return
        if not indexed:
            self.damage = "the bag ends without its index"

    def _record(self, fields, body, count_only):
        op = fields.get("op", b"\0")[0]
        if op == 0x07:  # connection
            conn = int.from_bytes(fields["conn"], "little")
            if conn not in self.connections:
                info = self._fields(body)
                self.connections[conn] = (fields["topic"].decode(), _ros_type(info["type"].decode()))
        elif op == 0x02:  # message data
            conn = int.from_bytes(fields["conn"], "little")
            t = fields["time"]
            ns = int.from_bytes(t[:4], "little") * 1_000_000_000 + int.from_bytes(t[4:8], "little")
            if count_only:
                self.counts[conn] = self.counts.get(conn, 0) + 1
            else:
                yield conn, ns, body

    def topics(self):
        return _topic_table(((conn, topic, msgtype) for conn, (topic, msgtype) in self.connections.items()),
                            self.counts)

    def messages(self, topic, msgtype):
        from rosbags.typesys import Stores, get_typestore
        store = get_typestore(Stores.ROS1_NOETIC)
        for conn, ns, body in self._messages():
            if self.connections[conn][0] == topic:
                yield ns, store.deserialize_ros1(body, msgtype)
        if self.damage is not None:
            raise _Damaged(self.damage)


class _Recording:
    """An open recording: its image topics and the messages of one. ROS 1
    and ROS 2 bags are read with rosbags, MCAP files with the mcap library;
    a ROS 1 bag or an MCAP file (alone or in a ROS 2 bag) cut short is read
    record by record up to the damage."""

    def __init__(self, path):
        self.path = os.fspath(path)
        self.kind = _kind(path)
        self.reader = self.file = None
        if self.kind == "mcap":
            _import_rosbags(path)  # the messages' deserialisers
            self._open_file(_McapFile, self.path)
            return
        AnyReader, Stores, get_typestore = _import_rosbags(path)
        store = Stores.ROS1_NOETIC if self.kind == "ros1" else Stores.ROS2_HUMBLE
        try:
            self.reader = AnyReader([pathlib.Path(path)], default_typestore=get_typestore(store))
            self.reader.open()
        except Exception as e:  # the readers' own, sqlite3's, struct's, zstd's...
            self.reader = None
            salvage = self._salvage()
            if salvage is None:
                _fail(path, f"truncated or damaged ({_reason(e)})")
            self._open_file(*salvage)

    def _salvage(self):
        """The reader of a file cut short, read up to the damage: a ROS 1 bag,
        or the MCAP file of a ROS 2 bag; None for others (SQLite cannot
        read a database cut short)."""
        p = pathlib.Path(self.path)
        if self.kind == "ros1":
            return _Ros1File, self.path
        files = sorted(p.glob("*.mcap")) if p.is_dir() else []
        return (_McapFile, str(files[0])) if len(files) == 1 else None

    def _open_file(self, cls, file):
        try:
            self.file = cls(file)
        except Error:
            raise
        except Exception as e:
            _fail(self.path, f"truncated or damaged ({_reason(e)})")

    def close(self):
        try:
            if self.reader is not None:
                self.reader.close()
        except Exception:  # closing after a read error
            pass

    def topics(self):
        """{topic: (message type, message count)} of every topic (of the
        messages before the damage in a file cut short)."""
        if self.file is not None:
            return self.file.topics()
        return {name: (info.msgtype, info.msgcount) for name, info in self.reader.topics.items()}

    def connections(self, topic):
        """(topic as the recording names it, message type, message count) of
        `topic` (accepted with or without its leading slash); raises Error
        when it is missing or holds no images."""
        topics = self.topics()
        name = topic
        if name not in topics:
            alt = name[1:] if name.startswith("/") else "/" + name
            name = alt if alt in topics else None
        if name is None:
            images = [t for t, (mt, _) in sorted(topics.items()) if mt in (IMAGE_TYPE, COMPRESSED_TYPE)]
            damage = self.file.damage if self.file is not None else None
            if damage is not None:
                _fail(self.path, f"truncated or damaged before any message of '{topic}' ({damage})")
            _fail(self.path, f"no topic '{topic}' (image topics: {', '.join(images) if images else 'none'})")
        msgtype, count = topics[name]
        if msgtype not in (IMAGE_TYPE, COMPRESSED_TYPE):
            _fail(self.path, f"topic '{name}' holds {msgtype}, not sensor_msgs/Image or sensor_msgs/CompressedImage")
        return name, msgtype, count

    def messages(self, topic, msgtype):
        """(log_time, message) of the topic in the recording's order; raises
        _Damaged where the recording breaks off."""
        if self.file is not None:
            yield from self.file.messages(topic, msgtype)
            return
        reader = self.reader
        connections = [c for c in reader.connections if c.topic == topic]
        messages = reader.messages(connections=connections)
        while True:
            try:
                item = next(messages, None)
                if item is None:
                    return
                connection, log_time, raw = item
                msg = reader.deserialize(raw, connection.msgtype)
            except Exception as e:
                raise _Damaged(_reason(e)) from None
            yield log_time, msg

    def only_image_topic(self):
        images = [t for t, (mt, _) in sorted(self.topics().items()) if mt in (IMAGE_TYPE, COMPRESSED_TYPE)]
        if not images and self.file is not None and self.file.damage is not None:
            _fail(self.path, f"truncated or damaged before any image message ({self.file.damage})")
        if len(images) != 1:
            _fail(self.path, "no image topic" if not images else
                  f"{len(images)} image topics ({', '.join(images)}): choose one")
        return images[0]


def bag_topics(path):
    """{topic: (message type, message count)} of a recording, e.g.
    {'/camera/image_raw': ('sensor_msgs/msg/Image', 3000)}."""
    rec = _Recording(path)
    try:
        return rec.topics()
    finally:
        rec.close()


def _to_grey(image, path, index):
    """An image as OpenCV decoded it (grey, BGR or BGRA; 8 or 16 bits) to
    8-bit grey as panoloc converts an image file's frames."""
    import cv2
    if image.ndim == 3 and image.shape[2] == 3:
        image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    elif image.ndim == 3 and image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2GRAY)
    elif image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    elif image.ndim != 2:
        _fail(path, f"message {index}: an image of {image.shape[2]} channels")
    if image.dtype != np.uint8:
        # 16 bits to 8 by the high byte (the camera's full range, as
        # cv_bridge does), rounded and saturated as OpenCV's convertTo.
        image = np.clip(np.rint(image.astype(np.float64) / 256.0), 0, 255).astype(np.uint8)
    return image


def _import_cv2(path):
    try:
        import cv2
    except ImportError:
        _fail(path, "colour, 16-bit and compressed (JPEG, PNG) images need OpenCV's Python module cv2 "
                    "(apt install python3-opencv, or pip install opencv-python-headless)")
    return cv2


def _raw_grey(msg, path, index):
    """The grey frame of a sensor_msgs/Image message."""
    encoding = msg.encoding.lower()
    layout = IMAGE_ENCODINGS.get(encoding)
    if layout is None:
        _fail(path, f"message {index}: image encoding '{msg.encoding}' is not read (expected one of "
                    "mono8, rgb8, bgr8, rgba8, bgra8, mono16, rgb16, bgr16, 8UC1, 8UC3, 16UC1)")
    channels, size = layout
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    data = np.asarray(msg.data, dtype=np.uint8)
    if h <= 0 or w <= 0 or step < w * channels * size or len(data) < step * h:
        _fail(path, f"message {index}: {len(data)} bytes of data for a {w}x{h} {msg.encoding} image "
                    f"with rows of {step} bytes")
    rows = data[:step * h].reshape(h, step)[:, :w * channels * size]
    if size == 2:
        rows = np.ascontiguousarray(rows).view(">u2" if msg.is_bigendian else "<u2").astype(np.uint16)
    image = rows.reshape(h, w, channels) if channels > 1 else rows.reshape(h, w)
    if encoding.startswith("rgb"):
        image = image[:, :, [2, 1, 0] + ([3] if channels == 4 else [])]
    if channels == 1 and size == 1:
        return np.ascontiguousarray(image)
    _import_cv2(path)
    return _to_grey(np.ascontiguousarray(image), path, index)


def _compressed_grey(msg, path, index, cv2):
    """The grey frame of a sensor_msgs/CompressedImage message (JPEG, PNG)."""
    fmt = msg.format.lower()
    if "compresseddepth" in fmt or not any(k in fmt for k in ("jpeg", "jpg", "png")):
        _fail(path, f"message {index}: compressed image format '{msg.format}' is not read (expected jpeg or png)")
    data = np.asarray(msg.data, dtype=np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if len(data) else None
    if image is None:
        _fail(path, f"message {index}: cannot decode the {'PNG' if 'png' in fmt else 'JPEG'} data "
                    f"({len(data)} bytes)")
    return _to_grey(image, path, index)


def _stamp_ns(msg, log_time_ns):
    """The header stamp in nanoseconds; the recording time when the stamp is zero."""
    stamp = msg.header.stamp
    ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
    return ns if ns != 0 else int(log_time_ns)


class BagFrames:
    """The frames of one image topic of a recording, opened at once (a
    missing topic or a damaged file raises Error here). Iterating yields
    (grey frame, stamp_ns) in the recording's order: the frame uint8 H x W
    as panoloc would track it, stamp_ns the header stamp in integer
    nanoseconds (the recording time when the stamp is zero). Attributes:
    path, topic (as the recording names it), msgtype, count (messages)."""

    def __init__(self, path, topic=None):
        self.path = os.fspath(path)
        self._rec = _Recording(path)
        try:
            name = topic if topic is not None else self._rec.only_image_topic()
            self.topic, self.msgtype, self.count = self._rec.connections(name)
            self._cv2 = _import_cv2(path) if self.msgtype == COMPRESSED_TYPE else None
        except BaseException:
            self._rec.close()
            raise
        self._iter = None

    def __iter__(self):
        if self._iter is None:
            self._iter = self._frames()
        return self._iter

    def _frames(self):
        path = self.path
        compressed = self.msgtype == COMPRESSED_TYPE
        index = 0
        try:
            messages = self._rec.messages(self.topic, self.msgtype)
            while True:
                try:
                    item = next(messages, None)
                except _Damaged as e:
                    raise _Damaged(f"{path}: truncated or damaged at message {index} of {self.topic} ({e})") from None
                if item is None:
                    break
                log_time, msg = item
                grey = _compressed_grey(msg, path, index, self._cv2) if compressed else _raw_grey(msg, path, index)
                yield grey, _stamp_ns(msg, log_time)
                index += 1
        finally:
            self.close()

    def close(self):
        """Closes the recording (also done when iteration ends)."""
        if self._rec is not None:
            self._rec.close()
            self._rec = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._iter is not None:
            self._iter.close()
        self.close()
        return False


def read_bag_frames(path, topic=None):
    """BagFrames(path, topic): iterate for (grey frame, stamp_ns)."""
    return BagFrames(path, topic)


class _Prefetch:
    """Frames of read_bag_frames read and decoded on a thread of their own
    (the tracker releases the GIL), at most _PREFETCH ahead."""

    _END = object()

    def __init__(self, frames):
        self._frames = frames
        self._queue = queue.Queue(maxsize=_PREFETCH)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="panotrack-bag-reader", daemon=True)
        self._thread.start()

    def _put(self, item):
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def _run(self):
        try:
            for item in self._frames:
                if not self._put(item):
                    break
        except BaseException as e:  # handed to the consumer
            self._put(e)
            return
        finally:
            if self._stop.is_set():
                self._frames.close()
        self._put(self._END)

    def __iter__(self):
        return self

    def __next__(self):
        item = self._queue.get()
        if item is self._END:
            raise StopIteration
        if isinstance(item, BaseException):
            raise item
        return item

    def close(self):
        self._stop.set()
        self._thread.join()


def _wrap(theta):
    return math.atan2(math.sin(theta), math.cos(theta))


def format_pose_row(row):
    """A POSE_DTYPE row (or a dict of track()'s keys) as the line panoloc
    writes to its pose CSV (no newline; the library's own formatting)."""
    get = row.__getitem__
    theta = get("theta_rad") if "theta_rad" in _names(row) else get("theta")
    return _panotrack._format_pose_row(
        int(get("frame")), float(get("time_s")), str(get("status")), float(get("x")), float(get("y")),
        float(theta), int(get("n_landmarks")), float(get("residual")),
        [float(get(k)) for k in ("std_x", "std_y", "std_theta", "quality")])


def _names(row):
    return row.dtype.names if hasattr(row, "dtype") else row.keys()


POSE_CSV_HEADER = ",".join(POSE_DTYPE.names)  # panoloc's columns


def round_pose_rows(results):
    """track() results as a POSE_DTYPE array holding what panoloc's CSV
    holds: each value rounded as the CSV writes it and read back."""
    rows = np.empty(len(results), dtype=POSE_DTYPE)
    for i, r in enumerate(results):
        f = format_pose_row(r).split(",")
        rows[i] = (int(f[0]), float(f[1]), *(float(v) if v else math.nan for v in f[2:5]), f[5], int(f[6]),
                   *(float(v) if v else math.nan for v in f[7:]))
    return rows


def _without_path(err, path):
    """An error's message without the "PATH: " it starts with."""
    text = str(err)
    return text[len(path) + 2:] if text.startswith(path + ": ") else text


def localize_bag(path, topic=None, calibration=None, map=None, method="junction", init=None, num_threads=0,
                 return_summary=False, on_frame=None, view=None, **localizer_options):
    """Localises through the frames of one image topic of a ROS 1 bag, a
    ROS 2 bag (folder or .db3) or an MCAP file, as panoloc does through a
    video.

    Each frame (sensor_msgs/Image mono8, rgb8, bgr8, rgba8, bgra8, their
    16-bit forms, 8UC1/8UC3/16UC1; sensor_msgs/CompressedImage JPEG or PNG)
    is converted to grey as panoloc converts image files and tracked by the
    same localiser (panotrack.Localizer) at its header stamp; the rows are
    the ones panoloc would write to its pose CSV for those frames (same
    rounding), time_s the stamp in seconds (the localiser's motion model is
    given the time since the first frame, so that the rows do not depend on
    where the stamps' clock starts). Returns a numpy structured array
    of POSE_DTYPE; with return_summary, also a dict: input, topic, end (done,
    incomplete, not tracked, interrupted), error, frames, n_ok, n_lost,
    seconds, stamp_ns (int64 per row), covariance (per row, 3 x 3 over x, y,
    theta at full precision; NaN where the frame is not ok).

    topic: the image topic (None: the recording's only one). calibration,
    map: file paths or Calibration / Map objects. init: (x, y, theta) guess
    of the first pose; None: the case.yaml beside the recording, else a
    room-wide search (as panoloc). on_frame(index, grey, result): called
    after each frame (result: Localizer.track's dict). view: the run shown
    in Rerun as it goes (panotrack.viewer): True or "spawn" starts a viewer,
    a path ending in .rrd records the run there, "HOST:PORT" sends it to a
    viewer already running, a viewer.RunViewer is used as it is (and left
    open); None (the default): no viewer, nothing of it imported.
    localizer_options: search_px, min_step, alert_fraction.

    Raises panotrack.Error naming the recording for a missing topic, an
    unreadable encoding, a recording that cannot be opened or a first frame
    of a size other than the calibration's. A recording that breaks off (a
    ROS 1 bag or MCAP file cut short, a damaged message) or a frame of
    another size than the ones before it ends the run as incomplete with the
    rows before it, as panoloc ends a truncated video; error names the
    message. Warns when the run ended early or too few frames were tracked.
    """
    import warnings
    if calibration is None or map is None:
        raise TypeError("localize_bag: calibration and map are required")
    path = os.fspath(path)
    if init is None:
        init = _panotrack._initial_pose_beside(path)
    start = time.monotonic()
    # The recording and its topic are checked before the localiser's set-up.
    source = BagFrames(path, topic)
    results, stamps = [], []
    end, error = "done", None
    prefetch = viewer = None
    try:
        # The first frame is decoded before the localiser's set-up: a frame
        # that cannot be read fails at once.
        frames = iter(source)
        try:
            first = next(frames, None)
        except _Damaged as e:
            first, end, error = None, "incomplete", _without_path(e, path)
        loc = Localizer(calibration, map, method=method, init=init, num_threads=num_threads, **localizer_options)
        if view is not None:
            from . import viewer as viewer_module
            viewer = viewer_module.open_viewer(view, loc.map)
        details = viewer is not None
        sensor = loc.calibration.sensor
        size = (sensor.image_width, sensor.image_height)
        if first is not None:
            h, w = first[0].shape
            if (w, h) != size:
                _fail(path, f"frame size {w}x{h} does not match the calibration's {size[0]}x{size[1]}")
            prefetch = _Prefetch(frames)
            pending = first
            while pending is not None:
                grey, stamp = pending
                index = len(results)
                if grey.shape != (size[1], size[0]):
                    end = "incomplete"
                    error = (f"frame {index} is {grey.shape[1]}x{grey.shape[0]}, the frames before it "
                             f"{size[0]}x{size[1]}")
                    break
                # The localiser is given the time since the first frame (its
                # motion model needs only differences, which 1.7e9 s epoch
                # times would round); the row keeps the stamp.
                if not stamps:
                    stamp0 = stamp
                r = loc.track(grey, (stamp - stamp0) / 1_000_000_000, details)
                r["time_s"] = stamp / 1_000_000_000
                results.append(r)
                stamps.append(stamp)
                if viewer is not None:
                    viewer.log_frame(index, grey, r)
                if on_frame is not None:
                    on_frame(index, grey, r)
                try:
                    pending = next(prefetch, None)
                except _Damaged as e:
                    end, error = "incomplete", _without_path(e, path)
                    break
    except KeyboardInterrupt:
        if not return_summary:
            raise
        end, error = "interrupted", "interrupted"
    finally:
        if prefetch is not None:
            prefetch.close()
        source.__exit__(None, None, None)
        if viewer is not None and viewer is not view:
            viewer.close()
    rows = round_pose_rows(results)
    n_ok = int((rows["status"] == "ok").sum())
    n_lost = int((rows["status"] == "lost").sum())
    frames_n = len(rows)
    if end == "done" and frames_n > 0 and (n_ok == 0 or (frames_n >= 20 and n_ok < 0.1 * frames_n)):
        end = "not tracked"
        error = (f"{path}: only {n_ok} of {frames_n} frames tracked (under 10 %); likely causes: a wrong "
                 "calibration or image size (--calib), a wrong initial pose (--init or case.yaml), wrong map "
                 "units, landmarks mis-measured or missing (check the map with panomap check)")
    cov = np.array([r["covariance"] for r in results], dtype=np.float64).reshape(-1, 3, 3)
    summary = {"input": path, "topic": source.topic, "msgtype": source.msgtype, "end": end, "error": error, "frames": frames_n, "n_ok": n_ok,
               "n_lost": n_lost, "seconds": time.monotonic() - start,
               "stamp_ns": np.array(stamps, dtype=np.int64), "covariance": cov}
    if end != "done" and not return_summary:
        warnings.warn(f"localize_bag: {end}: {error}", RuntimeWarning, stacklevel=2)
    return (rows, summary) if return_summary else rows


def _output_guard(out, inputs, force, what):
    """Refuses an output that is an input (or inside a ROS 2 bag folder given
    as input), or that exists without force."""
    out_p = pathlib.Path(out).resolve()
    for i in inputs:
        if i is None:
            continue
        in_p = pathlib.Path(i).resolve()
        if out_p == in_p or in_p in out_p.parents:
            raise Error(f"{os.fspath(out)}: the {what} would overwrite the input {os.fspath(i)}")
    if (out_p.exists() or os.path.lexists(out)) and not force:
        raise Error(f"{os.fspath(out)}: exists (use --force, or force=True, to replace it)")


def _yaw_quaternion(theta):
    half = 0.5 * _wrap(theta)
    return 0.0, 0.0, math.sin(half), math.cos(half)


def write_pose_mcap(path, rows, covariance, stamp_ns=None, metres_per_unit=1.0, map_frame="map",
                    base_frame="base_link", pose_topic="/panotrack/pose", tf_topic="/tf", inputs=(), force=False):
    """Writes the ok rows as ROS 2 messages to a new MCAP file (CDR
    encoding, ros2msg schemas), for RViz (ros2 bag play) and Foxglove:

    - `pose_topic`: geometry_msgs/PoseWithCovarianceStamped in `map_frame`,
      the position (x, y, 0) in metres (map units times metres_per_unit),
      the yaw theta as a quaternion about z, the 3 x 3 covariance over x, y,
      theta placed in the 6 x 6 (x, y, z, roll, pitch, yaw) at x, y, yaw and
      scaled to metres; z, roll and pitch 0 (a planar pose, as AMCL writes).
    - `tf_topic`: tf2_msgs/TFMessage with the transform map_frame ->
      base_frame of the same pose.

    Each message is logged and stamped at its frame's stamp (stamp_ns; None:
    the rows' time_s). rows: POSE_DTYPE; covariance: N x 3 x 3 (localize_bag's
    summary['covariance']). Written as PATH.partial, renamed when complete;
    refuses to replace an existing file without force, and any of `inputs`.
    Returns the number of poses written.
    """
    try:
        from mcap.writer import CompressionType, Writer
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise Error(f"{os.fspath(path)}: writing MCAP files needs the Python packages mcap and rosbags "
                    "(pip install mcap rosbags)") from None
    path = os.fspath(path)
    _output_guard(path, inputs, force, "pose MCAP")
    rows = np.asarray(rows)
    covariance = np.asarray(covariance, dtype=np.float64).reshape(-1, 3, 3)
    if len(covariance) != len(rows):
        raise ValueError(f"write_pose_mcap: {len(covariance)} covariances for {len(rows)} rows")
    if stamp_ns is None:
        stamp_ns = [int(round(t * 1e9)) for t in rows["time_s"]]
    if len(stamp_ns) != len(rows):
        raise ValueError(f"write_pose_mcap: {len(stamp_ns)} stamps for {len(rows)} rows")
    if not (metres_per_unit > 0 and math.isfinite(metres_per_unit)):
        raise ValueError("write_pose_mcap: metres_per_unit: expected a positive number")
    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    Point, Quaternion, Pose = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"], T["geometry_msgs/msg/Pose"]
    PoseCov, PoseCovStamped = T["geometry_msgs/msg/PoseWithCovariance"], T["geometry_msgs/msg/PoseWithCovarianceStamped"]
    Vector3, Transform = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Transform"]
    TransformStamped, TFMessage = T["geometry_msgs/msg/TransformStamped"], T["tf2_msgs/msg/TFMessage"]
    pose_type, tf_type = "geometry_msgs/msg/PoseWithCovarianceStamped", "tf2_msgs/msg/TFMessage"
    s = float(metres_per_unit)
    scale6 = np.array([s, s, 1.0])
    index6 = [0, 1, 5]
    partial = path + ".partial"
    written = 0
    try:
        with open(partial, "wb") as f:
            w = Writer(f, compression=CompressionType.ZSTD)
            w.start(profile="ros2", library="panotrack")
            channels = {}
            for topic, typ in ((pose_topic, pose_type), (tf_topic, tf_type)):
                schema = w.register_schema(name=typ, encoding="ros2msg",
                                           data=ts.generate_msgdef(typ, ros_version=2)[0].encode())
                channels[typ] = w.register_channel(topic=topic, message_encoding="cdr", schema_id=schema)
            for i, row in enumerate(rows):
                if row["status"] != "ok":
                    continue
                ns = int(stamp_ns[i])
                stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
                x, y = float(row["x"]) * s, float(row["y"]) * s
                q = Quaternion(*_yaw_quaternion(float(row["theta_rad"])))
                cov6 = np.zeros((6, 6))
                c = 0.5 * (covariance[i] + covariance[i].T)  # symmetric to the last bit
                cov6[np.ix_(index6, index6)] = c * np.outer(scale6, scale6)
                pose = PoseCovStamped(header=Header(stamp=stamp, frame_id=map_frame),
                                      pose=PoseCov(pose=Pose(position=Point(x, y, 0.0), orientation=q),
                                                   covariance=cov6.reshape(36)))
                tf = TFMessage(transforms=[TransformStamped(
                    header=Header(stamp=stamp, frame_id=map_frame), child_frame_id=base_frame,
                    transform=Transform(translation=Vector3(x, y, 0.0), rotation=q))])
                for typ, msg in ((pose_type, pose), (tf_type, tf)):
                    w.add_message(channel_id=channels[typ], log_time=ns, publish_time=ns,
                                  data=bytes(ts.serialize_cdr(msg, typ)), sequence=written)
                written += 1
            w.finish()
        os.replace(partial, path)
    except BaseException:
        if os.path.exists(partial):
            os.remove(partial)
        raise
    return written


def write_image_bag(path, frames, stamp_ns, topic="/camera/image", encoding="mono8", storage="sqlite3",
                    jpeg_quality=95, frame_id="camera", mcap_profile="ros2"):
    """Writes frames as one image topic of a new recording, for trials and
    tests: a ROS 1 bag (path ending .bag), an MCAP file (.mcap) of ROS 2
    messages (mcap_profile "ros2": cdr, ros2msg schemas) or ROS 1 messages
    ("ros1": ros1 encoding, ros1msg schemas), or a ROS 2 bag folder (any
    other path; storage sqlite3 or mcap).

    frames: uint8 grey (H x W) or BGR (H x W x 3) arrays; stamp_ns: each
    frame's header stamp in nanoseconds (also its recording time).
    encoding: a sensor_msgs/Image encoding (mono8, bgr8, rgb8, mono16: the
    grey values in the high byte, a 16-bit camera's range) or jpeg / png for
    sensor_msgs/CompressedImage (OpenCV's encoders, `jpeg_quality`).
    Returns the number of messages written.
    """
    from rosbags.typesys import Stores, get_typestore
    p = pathlib.Path(path)
    if p.exists():
        raise Error(f"{path}: exists")
    kind = "ros1" if p.suffix == ".bag" else "mcap" if p.suffix == ".mcap" else "ros2"
    if mcap_profile not in ("ros1", "ros2"):
        raise ValueError(f"write_image_bag: mcap_profile: expected ros1 or ros2, got '{mcap_profile}'")
    ros1 = kind == "ros1" or (kind == "mcap" and mcap_profile == "ros1")
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    T = ts.types
    compressed = encoding in ("jpeg", "png")
    msgtype = COMPRESSED_TYPE if compressed else IMAGE_TYPE
    if not compressed and encoding not in ("mono8", "bgr8", "rgb8", "mono16"):
        raise ValueError(f"write_image_bag: encoding: expected mono8, bgr8, rgb8, mono16, jpeg or png, got '{encoding}'")
    if compressed or encoding != "mono8":
        import cv2

    def message(frame, ns):
        stamp = T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        header = (T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame_id) if ros1
                  else T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id))
        colour = frame.ndim == 3
        if compressed:
            ext = ".jpg" if encoding == "jpeg" else ".png"
            params = [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)] if encoding == "jpeg" else []
            ok, buf = cv2.imencode(ext, frame, params)
            if not ok:
                raise Error(f"{path}: cannot encode a frame as {encoding}")
            return T[COMPRESSED_TYPE](header=header, format=encoding, data=np.asarray(buf, np.uint8).reshape(-1))
        if encoding == "mono8":
            img = frame if not colour else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        elif encoding == "mono16":
            img = (frame if not colour else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)).astype("<u2") << 8
        else:
            img = frame if colour else cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
            if encoding == "rgb8":
                img = img[:, :, ::-1]
        img = np.ascontiguousarray(img)
        h, w = img.shape[:2]
        return T[IMAGE_TYPE](header=header, height=h, width=w, encoding=encoding, is_bigendian=0,
                             step=img.strides[0], data=img.view(np.uint8).reshape(-1))

    serialize = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    n = 0
    if kind == "mcap":
        from mcap.writer import CompressionType, Writer
        with open(p, "wb") as f:
            w = Writer(f, compression=CompressionType.NONE)
            w.start(profile=mcap_profile, library="panotrack")
            if ros1:  # as ROS 1 names its types: sensor_msgs/Image
                schema = w.register_schema(name=msgtype.replace("/msg/", "/"), encoding="ros1msg",
                                           data=ts.generate_msgdef(msgtype, ros_version=1)[0].encode())
            else:
                schema = w.register_schema(name=msgtype, encoding="ros2msg",
                                           data=ts.generate_msgdef(msgtype, ros_version=2)[0].encode())
            channel = w.register_channel(topic=topic, message_encoding="ros1" if ros1 else "cdr", schema_id=schema)
            for frame, ns in zip(frames, stamp_ns):
                ns = int(ns)
                w.add_message(channel_id=channel, log_time=ns, publish_time=ns, sequence=n,
                              data=bytes(serialize(message(frame, ns), msgtype)))
                n += 1
            w.finish()
        return n
    if kind == "ros1":
        from rosbags.rosbag1 import Writer
        writer = Writer(p)
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer
        plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}[storage]
        writer = Writer(p, version=9, storage_plugin=plugin)
    with writer:
        conn = writer.add_connection(topic, msgtype, typestore=ts)
        for frame, ns in zip(frames, stamp_ns):
            ns = int(ns)
            writer.write(conn, ns, serialize(message(frame, ns), msgtype))
            n += 1
    return n
