"""What the command line leaves behind and how it ends: file modes, a closed stdout,
``-v`` after the command, ``--version``."""

import io
import os
import stat

import pytest

from stereo_terrain import __version__
from stereo_terrain.cli import main
from stereo_terrain.cli.outputs import replace_from_temp
from stereo_terrain.synthetic import default_scene_spec, render_scene, write_scene

from .cli_run import run_cli


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    return write_scene(render_scene(default_scene_spec()), tmp_path_factory.mktemp("scene") / "s")


def _reconstruct_args(d, *extra):
    return ["reconstruct", d / "left.png", d / "right.png", "--calib", d / "calib.yaml", *extra]


def _mode(path):
    return stat.S_IMODE(path.stat().st_mode)


def test_a_new_output_file_gets_the_umask_mode_and_a_replaced_one_keeps_its_own(tmp_path):
    old = os.umask(0o022)
    try:
        new = tmp_path / "new.json"
        replace_from_temp(new, lambda tmp: tmp.write_text("{}"))
        assert _mode(new) == 0o644  # not mkstemp's 0600
        kept = tmp_path / "kept.json"
        kept.write_text("old")
        kept.chmod(0o640)
        replace_from_temp(kept, lambda tmp: tmp.write_text("new"))
        assert kept.read_text() == "new" and _mode(kept) == 0o640
    finally:
        os.umask(old)


def test_reconstruct_json_is_readable_by_others_under_the_usual_umask(scene_dir, tmp_path, capsys):
    old = os.umask(0o022)
    try:
        code, _, err = run_cli(_reconstruct_args(scene_dir, "--json", tmp_path / "r.json"), capsys)
    finally:
        os.umask(old)
    assert code == 0, err
    assert _mode(tmp_path / "r.json") == 0o644


class _ClosedPipe(io.StringIO):
    """A stdout whose reader went away (``... | head -1``)."""

    def write(self, s):
        raise BrokenPipeError(32, "Broken pipe")

    def fileno(self):
        raise io.UnsupportedOperation("no file descriptor")


def test_a_closed_stdout_is_not_an_internal_error_and_the_files_are_still_written(
    scene_dir, tmp_path, monkeypatch, capsys
):
    monkeypatch.setattr("sys.stdout", _ClosedPipe())
    plot = tmp_path / "r.png"
    code = main([str(a) for a in _reconstruct_args(scene_dir, "--json", "-", "--plot", plot)])
    assert code == 0
    assert "internal error" not in capsys.readouterr().err
    assert plot.stat().st_size > 10_000


def test_printing_after_the_reader_left_is_dropped_and_the_command_goes_on():
    from stereo_terrain.cli import _StdoutReaderMayLeave

    out = _StdoutReaderMayLeave(_ClosedPipe())
    assert out.write("first") == 5 and out.reader_gone
    assert out.write("more") == 4  # dropped, no error
    out.flush()


def test_verbose_after_the_command_and_version(scene_dir, capsys):
    code, out, err = run_cli(_reconstruct_args(scene_dir, "-v"), capsys)
    assert code == 0, err
    assert "obstacle:" in out
    code, out, _ = run_cli(["--version"], capsys)
    assert code == 0 and __version__ in out


def test_an_output_that_is_an_input_is_refused_and_the_input_kept(scene_dir, tmp_path, capsys):
    left = tmp_path / "left.png"
    left.write_bytes((scene_dir / "left.png").read_bytes())
    before = left.read_bytes()
    args = ["reconstruct", left, scene_dir / "right.png", "--calib", scene_dir / "calib.yaml", "--json", left]
    code, _, err = run_cli(args, capsys)
    assert code == 2 and "one of the inputs" in err and len(err.strip().splitlines()) == 1
    assert left.read_bytes() == before
    out = ["disparity", left, scene_dir / "right.png", "--calib", scene_dir / "calib.yaml", "--out", left]
    code, _, err = run_cli(out, capsys)
    assert code == 2 and "one of the inputs" in err
    assert left.read_bytes() == before
    # every output option, of every command, against every input (here the rig file)
    rig = tmp_path / "rig.yaml"
    rig.write_text((scene_dir / "rig.yaml").read_text())
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--rig", rig, "--json", rig), capsys)
    assert code == 2 and "one of the inputs" in err
    assert rig.read_text() == (scene_dir / "rig.yaml").read_text()


def test_no_output_overwrites_a_file_a_folder_or_glob_argument_reads(scene_dir, tmp_path, capsys):
    """The inputs are also every file of ``bench``'s scene folders and of a recording
    folder, what a ``calibrate`` glob matches, and a video given as a camera: an output
    naming one of them was written over it (a scene's truth.json by ``bench --json``, a
    recorded image by ``replay --summary-json``). A new file in those folders is fine."""
    import shutil

    scenes = tmp_path / "scenes"
    shutil.copytree(scene_dir, scenes / "s0")
    truth = scenes / "s0" / "truth.json"
    before = truth.read_bytes()
    code, _, err = run_cli(["bench", scenes, "--repeat", "1", "--json", truth], capsys)
    assert code == 2 and "one of the inputs" in err and len(err.strip().splitlines()) == 1
    assert truth.read_bytes() == before
    image = scenes / "s0" / "left.png"
    code, _, err = run_cli(
        ["calibrate", "--left", str(scenes / "s0" / "l*.png"), "--right", str(scenes / "s0" / "r*.png"),
         "--pattern", "9x6", "--square", "0.025", "--out", tmp_path / "c.yaml", "--figure", image],
        capsys,
    )  # fmt: skip
    assert code == 2 and "one of the inputs" in err
    assert image.read_bytes() == (scene_dir / "left.png").read_bytes()
    new = scenes / "s0" / "new.json"
    for _ in range(2):  # a new file beside them, written and written again
        code, _, err = run_cli(["bench", scenes, "--repeat", "1", "--json", new], capsys)
        assert code == 0, err
        assert new.is_file()


def test_two_outputs_may_not_name_one_file(scene_dir, tmp_path, capsys):
    """``--mcap X --json X``: the second written replaced the first (the MCAP became JSON)."""
    same = tmp_path / "both.out"
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--json", same, "--mcap", same), capsys)
    assert code == 2 and "give each output its own file" in err and len(err.strip().splitlines()) == 1
    assert not same.exists()


def test_verbose_before_and_after_the_command_is_parsed():
    from stereo_terrain.cli import build_parser

    argv = ["reconstruct", "l.png", "r.png", "--calib", "c.yaml"]
    assert build_parser().parse_args(["-v", *argv]).verbose
    assert build_parser().parse_args([*argv, "-v"]).verbose
    assert not build_parser().parse_args(argv).verbose


def test_a_figure_that_cannot_be_written_leaves_no_json(scene_dir, tmp_path, monkeypatch, capsys):
    """The JSON (the result) is written last: a figure or a recording that fails leaves
    no JSON that looks like success (found in review)."""
    import stereo_terrain.cli.scene as scene_cli
    from stereo_terrain.errors import InputError

    def fail(result, path):
        raise InputError(f"cannot write {path}: No such file or directory")

    monkeypatch.setattr(scene_cli, "_plot", fail)
    out = tmp_path / "r.json"
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--json", out, "--plot", tmp_path / "r.png"), capsys)
    assert code == 2 and "cannot write" in err
    assert not out.exists()


def test_a_recording_that_cannot_be_written_leaves_no_figure_and_loses_nothing(
    scene_dir, tmp_path, monkeypatch, capsys
):
    """Found in review: ``reconstruct --plot FIG --mcap OUT`` whose MCAP failed left the
    figure written before it. Every output or none: a late failure (a full disk) leaves
    none new and every older file as it was, and no temporary file."""
    pytest.importorskip("mcap")
    pytest.importorskip("matplotlib")
    from stereo_terrain.errors import InputError
    from stereo_terrain.ros.mcap_out import McapSink

    def fail(self):
        self.abort()
        raise InputError(f"cannot write {self.target}: No space left on device")

    monkeypatch.setattr(McapSink, "close", fail)
    fig, mcap, out = tmp_path / "r.png", tmp_path / "r.mcap", tmp_path / "r.json"
    argv = _reconstruct_args(scene_dir, "--plot", fig, "--mcap", mcap, "--json", out)
    code, _, err = run_cli(argv, capsys)
    assert code == 2 and "No space left" in err and err.count("\n") == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    fig.write_bytes(b"older figure")
    code, _, err = run_cli(argv, capsys)
    assert code == 2 and sorted(p.name for p in tmp_path.iterdir()) == ["r.png"]
    assert fig.read_bytes() == b"older figure"
    # the extra that writes the MCAP (its compression) is checked before any work
    monkeypatch.undo()
    monkeypatch.setitem(__import__("sys").modules, "zstandard", None)
    fig.unlink()
    code, _, err = run_cli(argv, capsys)
    assert code == 2 and "zstandard" in err and "stereo-terrain[ros]" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_python_dash_m_runs_the_command_line():
    import subprocess
    import sys

    argv = [sys.executable, "-m", "stereo_terrain", "--version"]
    proc = subprocess.run(argv, capture_output=True, text=True)
    assert proc.returncode == 0 and __version__ in proc.stdout


def test_demo_and_simulate_check_their_files_before_any_work(tmp_path, capsys):
    """A folder named like one of their outputs failed the figure at the end, after the
    scene (demo) or the summary (simulate) was written over."""
    pytest.importorskip("matplotlib", reason="the figures need the viz extra")
    demo = tmp_path / "demo"
    (demo / "demo.png").mkdir(parents=True)
    code, _, err = run_cli(["demo", "--out", demo], capsys)
    assert code == 2 and "demo.png" in err and "folder" in err
    assert sorted(p.name for p in demo.iterdir()) == ["demo.png"]
    scene_file = tmp_path / "demo2" / "scene"  # the scene's folder, taken by a file
    scene_file.parent.mkdir()
    scene_file.write_text("mine\n")
    code, _, err = run_cli(["demo", "--out", scene_file.parent, "--no-plot"], capsys)
    assert code == 2 and "scene" in err and "not a folder" in err
    assert scene_file.read_text() == "mine\n" and sorted(p.name for p in scene_file.parent.iterdir()) == [
        "scene"
    ]
    sim = tmp_path / "sim"
    (sim / "approach.png").mkdir(parents=True)
    (sim / "summary.json").write_text("{}\n")
    code, _, err = run_cli(["simulate", "--out", sim, "--size", "96x72", "--fps", "5"], capsys)
    assert code == 2 and "approach.png" in err
    assert (sim / "summary.json").read_text() == "{}\n"


def test_an_output_that_is_a_link_is_written_where_it_leads(scene_dir, tmp_path, capsys):
    """As a shell's ``>`` does: the link stays, its file gets the result (it was replaced
    by a regular file, the link lost)."""
    real = tmp_path / "results" / "run.json"
    real.parent.mkdir()
    real.write_text("{}\n")
    link = tmp_path / "latest.json"
    link.symlink_to(real)
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--json", link), capsys)
    assert code == 0, err
    assert link.is_symlink() and link.resolve() == real.resolve()
    assert '"obstacle"' in real.read_text()
