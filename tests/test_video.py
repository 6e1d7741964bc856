"""Reading frames: container timestamps, image folders, timing reports."""

import fractions

import av
import cv2
import numpy as np
import pytest

from cranktrack.errors import CranktrackError
from cranktrack.synthetic.video import VideoWriter
from cranktrack.tracker.video import Frame, open_frames, timing_report


def test_variable_frame_rate_timestamps_are_read_not_assumed(tmp_path):
    # Written with uneven times and two dropped frames; index/fps would be wrong.
    times = [0.0, 0.033, 0.067, 0.100, 0.200, 0.233, 0.280, 0.300]
    with VideoWriter(tmp_path / "vfr.mp4", 64, 48, 30.0, lossless=True) as w:
        for t in times:
            w.write(np.full((48, 64, 3), 128, np.uint8), t)
    src = open_frames(tmp_path / "vfr.mp4")
    got = [f.t_s for f in src.frames()]
    np.testing.assert_allclose(got, times, atol=1e-4)
    rep = timing_report(np.array(got), src.nominal_fps)
    assert rep["variable_rate"]
    assert rep["gaps"] == 1 and rep["dropped_frames_estimate"] == 2


def test_a_constant_rate_stored_in_whole_milliseconds_is_not_variable():
    t = np.round(np.arange(200) / 30.0, 3)  # 33, 33, 34 ms … as MKV or some MP4s store it
    rep = timing_report(t, 30.0)
    assert not rep["variable_rate"] and rep["timestamp_resolution_s"] == pytest.approx(1e-3)
    # A real change of rate at the same resolution still is.
    t2 = np.round(np.concatenate([np.arange(100) / 30.0, 100 / 30.0 + np.arange(100) / 24.0]), 3)
    assert timing_report(t2, 30.0)["variable_rate"]


def test_constant_rate_report():
    rep = timing_report(np.arange(100) / 25.0, 25.0)
    assert not rep["variable_rate"] and rep["gaps"] == 0
    assert rep["median_fps"] == pytest.approx(25.0)
    dup = timing_report(np.array([0.0, 0.04, 0.04, 0.08]))
    assert dup["duplicated_timestamps"] == 1


def test_image_folder_in_natural_order(tmp_path):
    for i in (10, 2, 1):
        img = np.full((20, 30, 3), i, np.uint8)
        cv2.imwrite(str(tmp_path / f"frame_{i}.png"), img)
    src = open_frames(tmp_path, fps=10.0)
    frames = list(src.frames())
    assert [int(f.rgb[0, 0, 0]) for f in frames] == [1, 2, 10]
    assert [f.t_s for f in frames] == [0.0, 0.1, 0.2]
    with pytest.raises(CranktrackError, match="--fps"):
        open_frames(tmp_path)


def test_frames_say_whether_their_chroma_is_full_resolution(tmp_path):
    # What decides whether the tracker may read luminance edges (edges.fit_edges).
    img = np.full((48, 64, 3), 128, np.uint8)
    for lossless, full in ((True, True), (False, False)):  # RGB H.264 vs 4:2:0 H.264
        name = tmp_path / f"v{lossless}.mp4"
        with VideoWriter(name, 64, 48, 30.0, lossless=lossless) as w:
            w.write(img, 0.0)
        assert [f.full_chroma for f in open_frames(name).frames()] == [full]
    for suffix, full in ((".png", True), (".jpg", False)):
        folder = tmp_path / suffix[1:]
        folder.mkdir()
        cv2.imwrite(str(folder / f"1{suffix}"), img)
        assert [f.full_chroma for f in open_frames(folder, fps=1.0).frames()] == [full]


def test_empty_folder_and_missing_path(tmp_path):
    with pytest.raises(CranktrackError, match="no images"):
        open_frames(tmp_path)
    with pytest.raises(CranktrackError, match="does not exist"):
        open_frames(tmp_path / "missing.mp4")


def test_h264_frames_keep_the_decoders_planes_and_convert_like_ffmpeg(tmp_path):
    # FFmpeg's own RGB conversion of the same frames is the second method: the
    # tracker's region-by-region conversion must agree with it to a few DN and
    # a region must be exactly that part of the whole frame.
    import av

    rng = np.random.default_rng(2)
    img = rng.integers(0, 256, (96, 128, 3), dtype=np.uint8)
    img = cv2.GaussianBlur(img, (0, 0), 3)  # a scene, not noise the codec would drop
    with VideoWriter(tmp_path / "h264.mp4", 128, 96, 30.0) as w:
        for k in range(3):
            w.write(img, k / 30)
    frames = list(open_frames(tmp_path / "h264.mp4").frames())
    assert frames[0].layout == "i420" and frames[0].size == (128, 96)
    with av.open(str(tmp_path / "h264.mp4")) as c:
        ffmpeg = [f.to_ndarray(format="rgb24") for f in c.decode(c.streams.video[0])]
    for mine, ref in zip(frames, ffmpeg, strict=True):
        d = np.abs(mine.region(0, 0, 128, 96).astype(int) - ref)
        assert d.max() <= 3 and d.mean() < 2.5
        whole = mine.rgb
        for x0, y0, x1, y1 in ((7, 5, 40, 33), (0, 1, 3, 96), (101, 60, 128, 95)):
            # A fresh frame, so nothing is cached.
            fresh = Frame(mine.index, mine.t_s, mine.pixels, mine.layout, mine.full_chroma)
            np.testing.assert_array_equal(fresh.region(x0, y0, x1, y1), whole[y0:y1, x0:x1])
        # Regions inside one converted before are cut from it: the same pixels, each
        # the caller's own (writing to one changes no other), and their medians are
        # NumPy's.
        fresh = Frame(mine.index, mine.t_s, mine.pixels, mine.layout, mine.full_chroma)
        outer = fresh.region(10, 8, 70, 60)
        inner = fresh.region(20, 15, 41, 40)
        np.testing.assert_array_equal(inner, whole[15:40, 20:41])
        outer[:] = 0
        inner[:] = 0
        np.testing.assert_array_equal(fresh.region(20, 15, 41, 40), whole[15:40, 20:41])
        for x0, y0, x1, y1 in ((20, 15, 41, 40), (30, 30, 33, 34), (5, 5, 6, 6)):
            np.testing.assert_array_equal(
                fresh.median_rgb(x0, y0, x1, y1),
                np.median(whole[y0:y1, x0:x1].reshape(-1, 3), axis=0))


@pytest.mark.parametrize("how", ["yuvj420p", "color_range"])
def test_full_range_h264_keeps_the_planes_and_converts_like_ffmpeg(tmp_path, how):
    # Phones and webcams often store JPEG levels (0–255): as the older pixel format
    # "yuvj420p" or as yuv420p flagged full range. Read with video levels (16–235)
    # the scene below comes out up to 20 DN off FFmpeg's own RGB; read as full range,
    # within 2 DN (0.65 DN on average: FFmpeg's fixed-point coefficients).
    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, (96, 128, 3), dtype=np.uint8)
    img = cv2.GaussianBlur(img, (0, 0), 3)
    img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX)  # blacks and whites too
    path = tmp_path / "full.mp4"
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=30)
        stream.width, stream.height = 128, 96
        stream.pix_fmt = "yuvj420p" if how == "yuvj420p" else "yuv420p"
        stream.options = {"crf": "10"}
        if how == "color_range":
            stream.codec_context.color_range = 2
        for k in range(3):
            frame = av.VideoFrame.from_ndarray(img, format="rgb24")
            frame.color_range = 2
            frame = frame.reformat(format=stream.pix_fmt, dst_color_range=2)
            frame.pts = k
            for packet in stream.encode(frame):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    frames = list(open_frames(path).frames())
    assert frames[0].layout == "i420" and frames[0].full_range
    _converted_like_ffmpeg(path, frames, mean_dn=1.5, plain_off_dn=15)


def _converted_like_ffmpeg(path, frames, mean_dn, plain_off_dn):
    """Each frame within 3 DN of FFmpeg's own RGB of it (``mean_dn`` on average), and
    more than ``plain_off_dn`` off when read as plain BT.601 in video range."""
    with av.open(str(path)) as c:
        ffmpeg = [f.to_ndarray(format="rgb24") for f in c.decode(c.streams.video[0])]
    for mine, ref in zip(frames, ffmpeg, strict=True):
        d = mine.region(0, 0, 128, 96).astype(int) - ref
        assert np.abs(d).max() <= 3 and np.abs(d).mean() < mean_dn
        plain = Frame(mine.index, mine.t_s, mine.pixels, mine.layout).rgb
        assert np.abs(plain.astype(int) - ref).max() > plain_off_dn


@pytest.mark.parametrize(("tag", "matrix"), [("bt709", 709), ("bt2020nc", 2020)])
def test_hd_and_hdr_matrices_keep_the_planes_and_convert_like_ffmpeg(tmp_path, tag, matrix):
    # HD video (phones, most cameras) is in BT.709, a phone's HDR in BT.2020. They were
    # converted to RGB by FFmpeg whole, every frame: 0.95 s against 0.70 s for the
    # same 300 frames of 1080p in BT.601, whose planes are kept and read by region.
    rng = np.random.default_rng(4)
    img = cv2.GaussianBlur(rng.integers(0, 256, (96, 128, 3), dtype=np.uint8), (0, 0), 3)
    img = cv2.normalize(img, None, 16, 235, cv2.NORM_MINMAX)
    path = tmp_path / f"{tag}.mp4"
    with av.open(str(path), "w") as out:
        s = out.add_stream("libx264", rate=30,
                           options={"crf": "10", "x264-params": f"colormatrix={tag}"})
        s.width, s.height, s.pix_fmt = 128, 96, "yuv420p"
        for k in range(2):
            frame = av.VideoFrame.from_ndarray(img, format="rgb24").reformat(
                format="yuv420p", dst_colorspace=1 if matrix == 709 else 9)
            frame.pts = k
            out.mux(s.encode(frame))
        out.mux(s.encode())
    frames = list(open_frames(path).frames())
    assert frames[0].layout == "i420" and frames[0].matrix == matrix
    _converted_like_ffmpeg(path, frames, mean_dn=2.0, plain_off_dn=10)


def test_a_width_of_an_odd_number_of_cells_keeps_the_planes(tmp_path):
    # 854×480 ("480p" of 16:9) is 213.5 chroma cells wide: its frames were converted
    # whole by FFmpeg, every frame, as only widths a multiple of 4 kept their planes.
    path = tmp_path / "wide.mp4"
    img = cv2.GaussianBlur(np.random.default_rng(5).integers(0, 256, (96, 130, 3), np.uint8),
                           (0, 0), 2)
    with VideoWriter(path, 130, 96, 30.0) as w:
        w.write(img, 0.0)
    frame = next(open_frames(path).frames())
    assert frame.layout == "i420" and frame.size == (130, 96)
    with av.open(str(path)) as c:
        ref = next(c.decode(c.streams.video[0])).to_ndarray(format="rgb24")
    assert np.abs(frame.rgb.astype(int) - ref).max() <= 3
    assert np.abs(frame.region(101, 7, 129, 40).astype(int) - ref[7:40, 101:129]).max() <= 3


def test_an_h264_render_written_again_is_the_same(tmp_path):
    # The same frames must code to the same pictures, or no render (and no figure
    # measured on one) can be made again. A still scene with fresh sensor noise in
    # every frame, as the renders have: with libx264's macroblock-tree rate control
    # on, this test failed in 5 runs of 5.
    import av

    rng = np.random.default_rng(0)
    scene = cv2.GaussianBlur(rng.uniform(60, 200, (120, 160, 3)).astype(np.float32), (0, 0), 4)
    frames = [np.clip(scene + rng.normal(0, 2.5, scene.shape), 0, 255).astype(np.uint8)
              for _ in range(20)]

    def pictures(name: str) -> bytes:
        with VideoWriter(tmp_path / name, 160, 120, 30.0) as w:
            for k, f in enumerate(frames):
                w.write(f, k / 30)
        with av.open(str(tmp_path / name)) as c:
            return b"".join(bytes(f.planes[0]) for f in c.decode(c.streams.video[0]))

    first = pictures("first.mp4")
    assert all(pictures(f"{k}.mp4") == first for k in range(12))


def _grey(k: int) -> av.VideoFrame:
    return av.VideoFrame.from_ndarray(np.full((48, 64, 3), 10 + 3 * k, np.uint8), format="rgb24")


@pytest.mark.parametrize("pts_in_decoding_order", [False, True])
def test_b_frames_stored_with_decoding_order_times_get_display_order_times(
        tmp_path, pts_in_decoding_order):
    # Some webcam and phone muxers store B-frames with pts = dts (seen in OpenCV's own
    # sample box.mp4): the decoder still hands pictures over in display order, but each
    # with another's time. Written here with PyAV: frame k is grey level 10 + 3k.
    path = tmp_path / "b.mp4"
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=30, options={"bframes": "2", "g": "30"})
        stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
        frames = [_grey(k) for k in range(40)]
        for k, f in enumerate(frames):
            f.pts = k
        for f in [*frames, None]:
            for packet in stream.encode(f):
                if pts_in_decoding_order:
                    packet.pts = packet.dts
                out.mux(packet)
    src = open_frames(path)
    got = list(src.frames())
    t = np.array([f.t_s for f in got])
    grey = np.array([f.rgb.mean() for f in got])
    assert len(got) >= 36
    np.testing.assert_allclose(np.diff(t), 1 / 30, atol=2e-3)  # in order, no gaps
    assert np.all(np.diff(grey) > 1)  # and the pictures in the order they were filmed
    assert any("decoding order" in p for p in src.problems) == pts_in_decoding_order


def _grey_clip(path, shown, rate: int = 15, codec: str = "mjpeg", first: int = 0):
    """An MJPEG AVI (or ``codec`` in ``path``'s container) at ``rate`` fps holding a grey
    picture at each frame slot of ``shown`` (the slots between list no picture of their
    own), the first stamped at slot ``first``."""
    with av.open(str(path), "w") as out:
        stream = out.add_stream(codec, rate=rate)
        stream.width, stream.height = 64, 48
        stream.pix_fmt = "yuvj420p" if codec == "mjpeg" else "yuv420p"
        for k in shown:
            f = _grey(k)
            f.pts, f.time_base = k + first, fractions.Fraction(1, rate)
            for packet in stream.encode(f):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    return path


def test_an_avi_that_lists_repeated_frames_is_not_called_truncated(tmp_path):
    # AVI can list a frame slot without a picture (it repeats the one before): OpenCV's
    # sample tree.avi lists 444 frames over 29.6 s and holds 68 pictures.
    shown = [0, 1, 2, 5, 6, 7, 12, 20, 21, 29]
    path = _grey_clip(tmp_path / "sparse.avi", shown)
    src = open_frames(path)
    t = [f.t_s for f in src.frames()]
    np.testing.assert_allclose(t, np.array(shown) / 15, atol=1e-3)
    assert src.expected_frames == 30
    assert not any("truncated" in p for p in src.problems)
    assert any("holds 10 pictures" in p for p in src.problems), src.problems


def test_an_avi_cut_short_is_called_truncated_though_its_pictures_fill_what_is_left(
        tmp_path):
    # An AVI cut short keeps its header's frame count, while FFmpeg takes its duration
    # from the pictures left: OpenCV's vtest.avi cut to its first 2 MB lists 795 frames
    # (79.5 s at 10 fps) and holds 194 pictures over a "duration" of 19.6 s. Its
    # pictures fill that duration, as a sparse AVI's do (the test above), but the
    # listed frames do not fit in it: it is truncated.
    path = _grey_clip(tmp_path / "whole.avi", range(60))
    cut = tmp_path / "cut.avi"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    src = open_frames(cut)
    got = list(src.frames())
    assert 10 < len(got) < 50 and src.expected_frames == 60
    assert any("truncated or damaged" in p for p in src.problems), src.problems
    assert not any("not cut short" in p for p in src.problems)


def test_a_clip_trimmed_by_an_edit_list_is_not_called_truncated(tmp_path):
    # A clip trimmed in a phone's gallery, or cut by a stream copy, keeps the pictures
    # before its new start, stamped before 0, and an edit list that hides them: the
    # container lists them, FFmpeg drops them. A pendulum clip of bartekpacia/pendulum
    # lists 2057 and shows 1844, and was called "truncated or damaged".
    path = _grey_clip(tmp_path / "trimmed.mp4", range(60), 30, "libx264", first=-20)
    src = open_frames(path)
    t = [f.t_s for f in src.frames()]
    assert src.expected_frames == 60 and len(t) == 40  # 20 hidden by the edit list
    assert src.shown_frames == 40  # what a progress bar counts to
    np.testing.assert_allclose(t, np.arange(40) / 30, atol=1e-3)
    assert src.problems == []


def _pictures(folder, names, values=None):
    folder.mkdir(exist_ok=True)
    for k, name in enumerate(names):
        value = k if values is None else values[k]
        cv2.imwrite(str(folder / name), np.full((20, 30, 3), value, np.uint8))


def test_a_folders_frames_are_its_pictures_numbered_alike(tmp_path):
    # `inspect` on one of Tracker's frames wrote "…00_inspect.png" in among them; read
    # as the folder's pictures in name order, it became frame 1 of the clip. Here a
    # thumbnail and such a PNG (value 200) are left out, and said so.
    _pictures(tmp_path / "clip", [f"Car{k:02d}.jpg" for k in range(5)])
    _pictures(tmp_path / "clip", ["Car00_inspect.png", "thumbnail.png"], [200, 200])
    src = open_frames(tmp_path / "clip", fps=10.0)
    values = [int(f.rgb[0, 0, 0]) for f in src.frames()]
    assert len(values) == 5 and 200 not in values
    assert src.expected_frames == 5
    assert any("2 other picture(s)" in p and "Car00_inspect.png" in p for p in src.problems)
    # Pictures with no common numbering are all frames, in name order, as before.
    _pictures(tmp_path / "named", ["start.png", "middle.png", "end.png"])
    src = open_frames(tmp_path / "named", fps=1.0)
    assert len(list(src.frames())) == 3 and not src.problems


def test_two_numbered_sequences_in_one_folder_are_refused(tmp_path):
    # Two cameras' pictures in one folder, interleaved by name, make no clip.
    _pictures(tmp_path, [f"left{k}.png" for k in range(3)] + [f"right{k}.png" for k in range(3)])
    with pytest.raises(CranktrackError, match=r"2 numbered sequences.*folder of its own"):
        open_frames(tmp_path, fps=10.0)


def test_one_picture_of_a_numbered_sequence_is_not_taken_for_a_clip(tmp_path):
    # Tracked alone, one frame of a clip gives no motion; `inspect` may show it.
    _pictures(tmp_path / "clip", [f"frame_{k:03d}.png" for k in range(4)])
    one = tmp_path / "clip" / "frame_002.png"
    with pytest.raises(CranktrackError, match=r"one of 4 numbered pictures.*--fps"):
        open_frames(one)
    assert [int(f.rgb[0, 0, 0]) for f in open_frames(one, one_picture=True).frames()] == [2]
    _pictures(tmp_path / "alone", ["photo.png", "frame_1.png"])
    assert len(list(open_frames(tmp_path / "alone" / "frame_1.png").frames())) == 1


def test_a_picture_of_another_size_is_skipped_and_said(tmp_path):
    # Its pixels would put a marker elsewhere in the plane; it was tracked as a frame.
    _pictures(tmp_path, [f"f{k}.png" for k in range(4)])
    cv2.imwrite(str(tmp_path / "f2.png"), np.full((10, 15, 3), 2, np.uint8))
    src = open_frames(tmp_path, fps=10.0)
    frames = list(src.frames())
    assert [(f.index, f.t_s) for f in frames] == [(0, 0.0), (1, 0.1), (3, 0.3)]
    assert src.problems == ["f2.png is 15×10 px, not 30×20 like the folder's first picture, "
                            "and was skipped"]


def _stored_turned(path, upright, turns):
    """An H.264 file holding ``upright`` (RGB) as a phone stores it: the picture turned
    back by ``turns`` quarter turns, with a display rotation that turns it upright."""
    stored = np.ascontiguousarray(np.rot90(upright, -turns))
    with av.open(str(path), "w") as out:
        s = out.add_stream("libx264", rate=10, options={"crf": "0"})
        s.width, s.height, s.pix_fmt = stored.shape[1], stored.shape[0], "yuv420p"
        s.set_display_rotation(90 * turns)
        for k in range(3):
            f = av.VideoFrame.from_ndarray(stored, format="rgb24")
            f.pts, f.time_base = k, fractions.Fraction(1, 10)
            out.mux(s.encode(f))
        out.mux(s.encode())


@pytest.mark.parametrize("turns", [1, 2, 3])
def test_a_phones_turned_video_is_read_upright(tmp_path, turns):
    # A phone filming upright stores its pictures on their side and a display rotation;
    # players and OpenCV's reader show them upright, and a user's @X,Y and --roi are
    # read off that picture. The frames were read as stored, on their side.
    upright = np.full((64, 48, 3), 40, np.uint8)
    cv2.circle(upright, (14, 44), 5, (40, 200, 60), -1)  # a green disc low on the left
    path = tmp_path / f"turned{turns}.mp4"
    _stored_turned(path, upright, turns)
    src = open_frames(path)
    assert (src.width, src.height) == (48, 64)
    frame = next(src.frames())
    assert frame.size == (48, 64)
    green = frame.rgb[..., 1].astype(float) - frame.rgb[..., 0]
    ys, xs = np.nonzero(green > 80)
    assert abs(xs.mean() - 14) < 0.5 and abs(ys.mean() - 44) < 0.5
    assert any("turned" in p and "48×64" in p for p in src.problems)
    # The same pixels as OpenCV's own reader, which turns them upright too (within
    # the 3 DN between its YUV conversion and ours).
    ok, bgr = cv2.VideoCapture(str(path)).read()
    assert ok and bgr.shape[:2] == (64, 48)
    assert np.abs(frame.rgb.astype(int) - bgr[..., ::-1]).max() <= 4


HLG_BT2020 = ":colorprim=bt2020:transfer=arib-std-b67:colormatrix=bt2020nc"


@pytest.mark.parametrize(("encoder", "layout", "options", "bound"), [
    ("libx265", "yuv420p10le", {"x265-params": "log-level=error:lossless=1"}, 0.06),
    ("libx265", "yuv420p10le", {"x265-params": "log-level=error:lossless=1" + HLG_BT2020}, 0.06),
    ("libx265", "yuv420p12le", {"x265-params": "log-level=error:lossless=1"}, 0.06),
    ("libx264", "yuv422p10le", {"crf": "0"}, 0.06),
    ("libx264", "yuv422p", {"crf": "0"}, 0.06),
    ("rawvideo", "yuyv422", {}, 0.06),
    ("rawvideo", "uyvy422", {}, 0.06)])
def test_deep_and_422_video_put_the_markers_where_they_were_drawn(tmp_path, encoder, layout,
                                                                 options, bound):
    # Phones film HDR as 10-bit HEVC; video cameras write 10-bit 4:2:2, MJPEG webcams
    # 8-bit 4:2:2. FFmpeg's own RGB conversion of more than 8 bits put the chroma about
    # half a pixel left of where its 8-bit conversion of the same planes does: discs
    # drawn at whole pixels were found 0.45 px (4:2:0) and 0.41 px (4:2:2) off in x.
    # Its conversion of 8-bit 4:2:2 put them 0.07-0.09 px off, by column parity, and
    # of a webcam's packed YUYV and UYVY alike (0.09 px).
    from cranktrack.tracker.markers import parse_markers
    from cranktrack.tracker.track import track

    try:
        av.codec.Codec(encoder, "w")
    except av.codec.codec.UnknownCodecError:
        pytest.skip(f"this FFmpeg has no {encoder}")
    h, w = 96, 128
    path = tmp_path / "deep.mkv"
    with av.open(str(path), "w") as out:
        s = out.add_stream(encoder, rate=10, options=options)
        s.width, s.height, s.pix_fmt = w, h, layout
        for k in range(6):
            rgb = np.full((h, w, 3), 90, np.uint8)
            cv2.circle(rgb, (40 + 3 * k, 50), 10, (40, 190, 70), -1)  # green, RGB
            frame = av.VideoFrame.from_ndarray(rgb, format="rgb24").reformat(format=layout)
            frame.pts, frame.time_base = k, fractions.Fraction(1, 10)
            out.mux(s.encode(frame))
        out.mux(s.encode())
    tab = track(open_frames(path), parse_markers(["g=green"])).tracks
    assert tab["g_ok"].all()
    assert np.abs(tab["g_x_px"] - (40 + 3 * tab["frame"])).max() < bound
    assert np.abs(tab["g_y_px"] - 50).max() < bound


def test_nv12_is_read_as_the_4_2_0_planes_it_holds(tmp_path):
    # NV12 (hardware decoders and capture cards: U and V interleaved) was converted whole
    # by FFmpeg on every frame; as the planes of 4:2:0 it is converted only where a
    # marker is looked for, and its frames are those of the same video stored planar.
    from cranktrack.tracker.planes import plane_samples

    rgb = np.full((48, 64, 3), 90, np.uint8)
    cv2.circle(rgb, (30, 20), 8, (40, 190, 70), -1)
    planar = av.VideoFrame.from_ndarray(rgb, format="rgb24").reformat(format="yuv420p")
    # The same samples, U and V interleaved.
    nv12 = av.VideoFrame(64, 48, "nv12")
    np.frombuffer(nv12.planes[0], np.uint8).reshape(48, -1)[:, :64] = plane_samples(planar, 0)
    uv = np.frombuffer(nv12.planes[1], np.uint8).reshape(24, -1)
    uv[:, 0:64:2], uv[:, 1:64:2] = plane_samples(planar, 1), plane_samples(planar, 2)
    clips = {}
    for layout, frame in (("nv12", nv12), ("yuv420p", planar)):
        clips[layout] = tmp_path / f"{layout}.mkv"
        with av.open(str(clips[layout]), "w") as out:
            s = out.add_stream("rawvideo", rate=10)
            s.width, s.height, s.pix_fmt = 64, 48, layout
            frame.pts, frame.time_base = 0, fractions.Fraction(1, 10)
            out.mux(s.encode(frame))
            out.mux(s.encode())
    nv12, planar = (next(open_frames(clips[k]).frames()) for k in ("nv12", "yuv420p"))
    assert nv12.layout == planar.layout == "i420"
    np.testing.assert_array_equal(nv12.pixels, planar.pixels)


def _interlaced_disc(path, frames=8, speed_px_s=200.0, first="bottom", clock_frames=0):
    """A red disc moving along x at ``speed_px_s``, filmed interlaced at 25 frames a
    second: each frame's two fields taken 20 ms apart, each field's 4:2:0 colour from
    its own lines (as interlaced video codes them). The encoder flags the bottom field
    first (as it does frames that do not say which); ``first`` is the one taken first
    ("bottom", "top"), or "both" for both at once (progressive segmented frames). The
    file's clock starts ``clock_frames`` frames in. Returns the fields' times (s) from
    its first picture."""
    h, w = 96, 128

    def field(t, parity):
        big = np.full((h * 4, w * 4, 3), (190, 190, 185), np.uint8)
        centre = np.round(((np.array([30 + speed_px_s * t, 48.0]) + 0.5) * 4 - 0.5) * 64)
        cv2.circle(big, tuple(int(v) for v in centre), 8 * 4 * 64, (200, 40, 40), -1,
                   cv2.LINE_AA, 6)
        lines = np.ascontiguousarray(cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
                                     [parity::2])
        return av.VideoFrame.from_ndarray(lines, format="rgb24").reformat(
            format="yuv420p").to_ndarray()

    with av.open(str(path), "w") as out:
        s = out.add_stream("libx264", rate=25,
                           options={"crf": "6", "x264-params": "interlaced=1:tff=1"})
        s.width, s.height, s.pix_fmt = w, h, "yuv420p"
        for k in range(frames):
            top_s, bottom_s = {"bottom": (0.02, 0.0), "top": (0.0, 0.02), "both": (0.0, 0.0)}[first]
            bottom, top = field(k / 25 + bottom_s, 1), field(k / 25 + top_s, 0)
            # Interleaved row by row: in the luma, and in each chroma plane.
            planes = np.empty((h * 3 // 2, w), np.uint8)
            planes[0:h:2], planes[1:h:2] = top[:h // 2], bottom[:h // 2]
            for at in (h, h + h // 4):
                chroma = planes[at:at + h // 4].reshape(h // 2, w // 2)
                half = (at - h) // 2 + h // 2  # where this plane starts in a field's planes
                chroma[0::2] = top[half:half + h // 8].reshape(h // 4, w // 2)
                chroma[1::2] = bottom[half:half + h // 8].reshape(h // 4, w // 2)
            frame = av.VideoFrame.from_ndarray(planes, format="yuv420p")
            frame.pts, frame.time_base = clock_frames + k, fractions.Fraction(1, 25)
            out.mux(s.encode(frame))
        out.mux(s.encode())
    return np.arange(2 * frames) / 50


@pytest.mark.parametrize(("first", "name", "clock_frames"), [
    ("bottom", "interlaced.mp4", 0), ("top", "interlaced.mp4", 0),
    ("bottom", "camcorder.m2t", 35)])  # an HDV camcorder's transport stream, from 1.4 s
def test_an_interlaced_videos_fields_are_tracked_as_frames_of_their_own(tmp_path, first, name,
                                                                        clock_frames):
    # An interlaced camcorder's frame holds two fields 20 ms apart. Read as stored, a
    # disc moving 4 px a field was found in 12 frames of 12, each 2 px off where it was
    # at the frame's time, with a σ of 0.15 px. Now each field is a frame at its time.
    from cranktrack.tracker.markers import parse_markers
    from cranktrack.tracker.track import track

    # Taken top field first but flagged bottom first, the fields came out in the wrong
    # order (x ±4 px by field): which came first is read from the pictures (idet).
    path = tmp_path / name
    times = _interlaced_disc(path, first=first, clock_frames=clock_frames)
    source = open_frames(path)
    assert source.fields and source.nominal_fps == pytest.approx(50.0)
    assert any("interlaced" in p and "20 ms" in p for p in source.problems)
    tab = track(source, parse_markers(["b=red"])).tracks
    np.testing.assert_allclose(tab["t_s"], times, atol=1e-6)
    assert tab["b_ok"].all()
    assert np.abs(tab["b_x_px"] - (30 + 200 * tab["t_s"])).max() < 0.15
    # Each field's colour is coded from its own lines, half a line off where a frame's
    # cells hold it: without moving it back, y alternated by ±0.45 px field to field.
    assert np.abs(tab["b_y_px"] - 48).max() < 0.2


def _slow_motion(path, said_fps=None, frames=12, px_per_frame=3.0, first=0):
    """A red disc moving ``px_per_frame`` along x each frame, stored to play at 30
    frames a second, with the rate it was taken at written where Android's camera
    writes it (``said_fps``), if given; the first frame at ``first``/30 s of the file's
    clock."""
    options = {"movflags": "use_metadata_tags"} if said_fps else {}
    with av.open(str(path), "w", options=options) as out:
        if said_fps:
            out.metadata["com.android.capture.fps"] = f"{said_fps:.6f}"
        s = out.add_stream("libx264", rate=30, options={"crf": "4"})
        s.width, s.height, s.pix_fmt = 128, 96, "yuv420p"
        for k in range(frames):
            big = np.full((96 * 4, 128 * 4, 3), 200, np.uint8)
            x = 30 + px_per_frame * k
            cv2.circle(big, (round(((x + 0.5) * 4 - 0.5) * 64), round((48.5 * 4 - 0.5) * 64)),
                       8 * 4 * 64, (200, 40, 40), -1, cv2.LINE_AA, 6)
            picture = cv2.resize(big, (128, 96), interpolation=cv2.INTER_AREA)
            frame = av.VideoFrame.from_ndarray(picture, format="rgb24")
            frame.pts, frame.time_base = first + k, fractions.Fraction(1, 30)
            out.mux(s.encode(frame))
        out.mux(s.encode())


def test_times_count_from_the_start_of_the_files_clock(tmp_path):
    # MPEG transport streams (a camcorder's .MTS) start their clock late, as FFmpeg's
    # muxer does at 1.4 s: `--start 0.1` was 1.3 s before the first frame, and a player
    # shows that frame at 0.
    from cranktrack.tracker.markers import parse_markers
    from cranktrack.tracker.track import Span, track

    late = tmp_path / "camcorder.mts"
    _slow_motion(late, first=42)
    source = open_frames(late)
    assert source.clock_start_s == pytest.approx(1.4)
    assert any("clock starts at 1.4 s" in p for p in source.problems)
    assert [f.t_s for f in source.frames()][:3] == pytest.approx([0.0, 1 / 30, 2 / 30])
    tab = track(open_frames(late), parse_markers(["b=red"]), span=Span(0.1, 0.2)).tracks
    assert tab["frame"].tolist() == [3, 4, 5, 6]
    assert np.abs(tab["b_x_px"] - (30 + 90 * tab["t_s"])).max() < 0.2
    plain = tmp_path / "plain.mp4"
    _slow_motion(plain)
    source = open_frames(plain)
    assert source.clock_start_s == 0.0 and not source.problems
    # A start of a frame or two (an encoder's delay) is taken off without a word.
    delayed = tmp_path / "delayed.mp4"
    _slow_motion(delayed, first=2)
    source = open_frames(delayed)
    assert source.clock_start_s == pytest.approx(2 / 30, abs=2e-3) and not source.problems
    assert [f.t_s for f in source.frames()][:2] == pytest.approx([0.0, 1 / 30], abs=2e-3)


def test_slow_motion_is_timed_as_it_was_taken(tmp_path):
    # A phone's slow motion, taken at 240 frames a second, plays at 30: on the file's
    # clock the disc below moves at 90 px/s, 8 times slower than it did (720 px/s).
    from cranktrack.tracker.markers import parse_markers
    from cranktrack.tracker.track import track

    said = tmp_path / "android.mp4"
    _slow_motion(said, said_fps=240.0)
    source = open_frames(said)
    assert source.nominal_fps == pytest.approx(240.0) and source.time_scale == 0.125
    assert any("taken at 240 a second" in p and "--fps 30" in p for p in source.problems)
    tab = track(source, parse_markers(["b=red"])).tracks
    np.testing.assert_allclose(tab["t_s"], np.arange(12) / 240, atol=1e-9)
    speed = np.polyfit(tab["t_s"], tab["b_x_px"], 1)[0]
    assert speed == pytest.approx(720.0, rel=0.01)
    # Told by the user (a file that does not say), or kept as the file plays it.
    plain = tmp_path / "plain.mp4"
    _slow_motion(plain)
    assert not open_frames(plain).problems
    given = open_frames(plain, fps=120.0)
    assert [f.t_s for f in given.frames()][:3] == pytest.approx([0.0, 1 / 120, 2 / 120])
    assert open_frames(said, fps=30.0).time_scale == 1.0


def test_a_cover_picture_before_the_video_is_not_tracked(tmp_path):
    # A file whose first video stream is a one-picture cover (as some downloads and
    # editors write) was tracked as that one still frame.
    path = tmp_path / "covered.mkv"
    with av.open(str(path), "w") as out:
        cover = out.add_stream("mjpeg", rate=1)
        cover.width, cover.height, cover.pix_fmt = 64, 48, "yuvj420p"
        video = out.add_stream("libx264", rate=10)
        video.width, video.height, video.pix_fmt = 64, 48, "yuv420p"
        still = av.VideoFrame.from_ndarray(np.full((48, 64, 3), 200, np.uint8), format="rgb24")
        still.pts, still.time_base = 0, fractions.Fraction(1, 1)
        out.mux(cover.encode(still.reformat(format="yuvj420p")))
        out.mux(cover.encode())
        for k in range(5):
            frame = av.VideoFrame.from_ndarray(np.full((48, 64, 3), 40 * k, np.uint8),
                                               format="rgb24")
            frame.pts, frame.time_base = k, fractions.Fraction(1, 10)
            out.mux(video.encode(frame))
        out.mux(video.encode())
    source = open_frames(path)
    assert source.codec == "h264"
    assert len(list(source.frames())) == 5
    assert any("2 video streams" in p and "stream 1" in p for p in source.problems)


def test_twelve_bit_samples_in_sixteen_bit_pictures_are_found(tmp_path):
    # Scientific and high-speed cameras write 12-bit samples in 16-bit grey PNG or TIFF.
    # Read as OpenCV reads them for 8-bit colour (divided by 256), the white disc below
    # was 14 DN on 1 and found in none of the frames.
    from cranktrack.tracker.markers import parse_markers
    from cranktrack.tracker.track import track

    for k in range(6):
        big = np.full((96 * 4, 128 * 4), 300, np.uint16)
        cv2.circle(big, (round(((40 + 4 * k + 0.5) * 4 - 0.5) * 64), round((48.5 * 4 - 0.5) * 64)),
                   8 * 4 * 64, 3800, -1, cv2.LINE_AA, 6)
        cv2.imwrite(str(tmp_path / f"f{k:02d}.png"),
                    cv2.resize(big, (128, 96), interpolation=cv2.INTER_AREA))
    source = open_frames(tmp_path, fps=10.0)
    assert source.sample_bits == 12
    assert any("12-bit samples" in p for p in source.problems)
    tab = track(source, parse_markers(["ball=white"])).tracks
    assert tab["ball_ok"].all()
    assert np.abs(tab["ball_x_px"] - (40 + 4 * tab["frame"])).max() < 0.05
    assert np.abs(tab["ball_y_px"] - 48).max() < 0.05


def test_progressive_frames_flagged_interlaced_are_tracked_whole(tmp_path):
    # Some cameras flag progressive segmented frames interlaced: both fields one
    # instant. Split into fields, they moved in stairs at half the lines.
    path = tmp_path / "psf.mp4"
    _interlaced_disc(path, first="both")
    source = open_frames(path)
    assert not source.fields and source.nominal_fps == pytest.approx(25.0)
    assert any("one instant" in p for p in source.problems)
    assert len(list(source.frames())) == 8


def _white_disc(t: float) -> np.ndarray:
    """A white disc (radius 10 px) at (40 + 60 t, 30) px on dark grey, 96×64, drawn 4×
    over and averaged down."""
    big = np.full((64 * 4, 96 * 4, 3), 50, np.uint8)
    x = 40 + 60 * t
    cv2.circle(big, (round(((x + 0.5) * 4 - 0.5) * 64), round((30.5 * 4 - 0.5) * 64)),
               10 * 4 * 64, (230, 230, 230), -1, cv2.LINE_AA, 6)
    return cv2.resize(big, (96, 64), interpolation=cv2.INTER_AREA)


def test_pictures_without_colour_are_said_and_hue_markers_refused(tmp_path):
    # A monochrome camera (as many lab and high-speed cameras are) records brightness
    # alone: every marker found by hue was "not found in any frame; check its colour".
    from cranktrack.tracker.markers import parse_markers
    from cranktrack.tracker.track import track

    grey = tmp_path / "mono.mkv"
    with av.open(str(grey), "w") as out:
        s = out.add_stream("ffv1", rate=25)
        s.width, s.height, s.pix_fmt = 96, 64, "gray"
        for k in range(8):
            frame = av.VideoFrame.from_ndarray(_white_disc(k / 25), format="rgb24")
            frame = frame.reformat(format="gray")
            frame.pts, frame.time_base = k, fractions.Fraction(1, 25)
            out.mux(s.encode(frame))
        out.mux(s.encode())
    from cranktrack.tracker.video import colourless_note

    source = open_frames(grey)
    assert not source.stores_colour and source.pixel_format == "gray"
    assert "stored without colour" in colourless_note(source)
    with pytest.raises(CranktrackError, match="markers A, B, C, found by hue, cannot be seen"):
        track(source)
    white = track(open_frames(grey), parse_markers(["dot=white"]))
    tab = white.tracks
    assert tab["dot_ok"].all()
    assert not any("colour" in p for p in white.problems)  # named as it should be
    assert np.abs(tab["dot_x_px"] - (40 + 60 * tab["t_s"])).max() < 0.05
    # The same camera's pictures coded as colour video: flat chroma, said, not refused.
    coded = tmp_path / "mono.mp4"
    with VideoWriter(coded, 96, 64, 25.0, crf=18) as w:
        for k in range(4):
            w.write(_white_disc(k / 25), k / 25)
    source = open_frames(coded)
    assert source.stores_colour and not source.colour
    assert any("no colour in its first picture" in p for p in track(source).problems)
    # A folder of one-channel pictures is stored without colour too.
    folder = tmp_path / "frames"
    folder.mkdir()
    for k in range(3):
        cv2.imwrite(str(folder / f"f{k:03d}.png"), _white_disc(k / 25)[..., 0])
    assert not open_frames(folder, fps=25.0).stores_colour


def test_frames_of_another_size_part_way_are_skipped_and_said(tmp_path):
    # Two MPEG transport streams joined byte for byte (as recorders split and users
    # join them), the second at twice the size: its frames were tracked in the first's
    # pixels, the markers "not found" in them, and nothing said why.
    parts = []
    for k, (w, h) in enumerate([(64, 48), (128, 96)]):
        part = tmp_path / f"part{k}.ts"
        with av.open(str(part), "w") as out:
            s = out.add_stream("libx264", rate=10, options={"crf": "0"})
            s.width, s.height, s.pix_fmt = w, h, "yuv420p"
            for j in range(4):
                frame = av.VideoFrame.from_ndarray(np.full((h, w, 3), 90, np.uint8),
                                                   format="rgb24")
                frame.pts, frame.time_base = 4 * k + j, fractions.Fraction(1, 10)
                out.mux(s.encode(frame))
            out.mux(s.encode())
        parts.append(part.read_bytes())
    joined = tmp_path / "joined.ts"
    joined.write_bytes(b"".join(parts))
    source = open_frames(joined)
    frames = list(source.frames())
    assert [f.index for f in frames] == [0, 1, 2, 3]
    assert all(f.size == (64, 48) for f in frames)
    assert any("4 frame(s), from frame 4 to 7, are 128×96" in p for p in source.problems)


def test_a_folder_of_float_pictures_ends_in_one_sentence(tmp_path):
    # 32-bit float TIFFs (a scientific camera's export) are not pictures the reader
    # takes: opening the folder looked for colour in a picture it could not read.
    from cranktrack.tracker.track import track

    for k in range(3):
        cv2.imwrite(str(tmp_path / f"f{k}.tif"),
                    np.random.default_rng(k).random((24, 32, 3)).astype(np.float32))
    source = open_frames(tmp_path, fps=10.0)
    # The error says why (what reading the frames said).
    with pytest.raises(CranktrackError, match=r"could be decoded \(f0.tif could not be read "
                                              r"as an 8- or 16-bit picture"):
        track(source)
