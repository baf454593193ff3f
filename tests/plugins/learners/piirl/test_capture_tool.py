"""The capture tool: a key-driven probe recording a path, its browser page on loopback, and the headless command."""

import json
import subprocess
import sys
import urllib.error
import urllib.request

import numpy as np
import pliant
import pytest
from pliant.errors import ConfigError
from pliant_piirl.capture import CaptureSession
from pliant_piirl.capture_server import CaptureServer
from pliant_piirl.demonstration import load_demonstrations
from pliant_piirl.features import DeformationFeatures
from pliant_piirl.tasks import TaskSpace, rotation_onto

TIP = np.array([0.0, 0.0, -0.06])


@pytest.fixture(scope="module")
def cube():
    scene = pliant.load_scene("hollow-cube")
    task = TaskSpace(scene).generate_task("L1", "M1", np.random.default_rng(0), TIP, rotation_onto)
    return DeformationFeatures(scene), task


def insert_until_reached(session, limit=200):
    state = session.state()
    for _ in range(limit):
        if state["reached"]:
            break
        state = session.press("i")
    return state


def test_inserting_along_the_funnel_reaches_the_target_and_records_every_step(cube):
    features, task = cube
    session = CaptureSession(features, task, TIP)
    start_distance = session.state()["distance"]
    state = insert_until_reached(session)
    assert state["reached"] and state["refused"] == 0
    assert state["steps"] == pytest.approx(start_distance / session.step, abs=2)
    assert sum(state["path_deformation"].values()) > 0            # the probe passed the slot between L1 and M1
    demo = session.demonstration()
    assert demo.source == "capture" and len(demo.path) == state["steps"] + 1
    assert np.array_equal(demo.path[0], task.start)
    assert np.linalg.norm(session.tip_position(demo.path[-1]) - task.target) <= session.tolerance


def test_turns_keep_the_tip_moves_shift_it_undo_steps_back_and_planes_refuse(cube):
    features, task = cube
    session = CaptureSession(features, task, TIP)
    tip = session.tip_position()
    session.press("t")
    assert np.allclose(session.tip_position(), tip) and session.state()["steps"] == 1
    session.press("d")
    assert np.allclose(session.tip_position() - tip, [session.step, 0, 0])
    session.press("z")
    assert np.allclose(session.tip_position(), tip) and session.state()["steps"] == 1
    refused = [session.press("u")["accepted"] for _ in range(200)]         # turn about z until the funnel says no
    assert not all(refused) and session.state()["refused"] > 0
    with pytest.raises(ConfigError, match="unknown key"):
        session.press("x")
    with pytest.raises(ConfigError, match="mm from the target"):
        CaptureSession(features, task, TIP).demonstration()


def _call(url, body=None):
    request = urllib.request.Request(url, data=None if body is None else json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=30) as reply:
            return reply.status, reply.read()
    except urllib.error.HTTPError as error:
        return error.code, error.read()


def test_the_page_is_served_on_loopback_and_drives_the_session(cube, tmp_path):
    features, task = cube
    server = CaptureServer(CaptureSession(features, task, TIP), tmp_path / "demos.json", "hollow-cube")
    assert server.url.startswith("http://127.0.0.1:")
    server.serve_in_background()
    try:
        status, page = _call(server.url)
        assert status == 200 and b"<canvas" in page and b"hollow-cube" in page
        status, scene = _call(server.url + "scene")
        scene = json.loads(scene)
        assert status == 200 and scene["names"] == ["L1", "L2", "M1", "M2", "H1", "H2"]
        assert np.array(scene["top"]).shape == features.cost.grid.shape[:2]
        status, body = _call(server.url + "save", {})
        assert status == 400 and "from the target" in json.loads(body)["error"]
        status, body = _call(server.url + "key", {"key": "?"})
        assert status == 400 and "unknown key" in json.loads(body)["error"]
        state = json.loads(_call(server.url + "state")[1])
        for _ in range(200):
            if state["reached"]:
                break
            state = json.loads(_call(server.url + "key", {"key": "i"})[1])
        assert state["reached"] and len(state["tail"]) == 3
        status, body = _call(server.url + "save", {})
        assert status == 200
    finally:
        server.close()
    scene_name, demos = load_demonstrations(tmp_path / "demos.json")
    assert scene_name == "hollow-cube" and demos[0].source == "capture"


def test_the_headless_command_plays_keys_and_saves(cube, tmp_path):
    features, task = cube                            # the command generates the same task: pair L1 M1, seed 0
    presses = round(CaptureSession(features, task, TIP).state()["distance"] / 0.002)
    out = tmp_path / "demos.json"
    done = subprocess.run([sys.executable, "-m", "pliant.cli", "learn", "capture", "hollow-cube", "--pair", "L1", "M1",
                           "--keys", "i" * presses, "--output", str(out)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "saved to" in done.stdout and load_demonstrations(out)[1][0].source == "capture"
    done = subprocess.run([sys.executable, "-m", "pliant.cli", "learn", "capture", "hollow-cube", "--pair", "L1", "M1",
                           "--keys", "i" * (presses // 2), "--output", str(out)], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 2 and "mm from the target" in done.stderr
    done = subprocess.run([sys.executable, "-m", "pliant.cli", "learn", "capture", "hollow-cube", "--pair", "L1", "M1",
                           "--task", str(out), "--output", str(out)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 2 and "--pair" in done.stderr


def test_a_planar_robot_is_driven_in_the_plane_to_its_goal(tmp_path):
    scene = pliant.load_scene("planar-objects")
    from pliant_piirl.demonstration import DemonstrationTask

    task = DemonstrationTask(scene.start, np.r_[scene.goal[:2], 0.0], goal=scene.goal)
    session = CaptureSession(DeformationFeatures(scene), task, np.zeros(3), tolerance=scene.goal_tolerance)
    assert not session.press("t")["accepted"]                 # out of the plane: nothing moves
    state = session.press("u")
    assert state["accepted"] and session.configuration[2] == pytest.approx(scene.start[2] + session.turn)
    session.press("j")
    state = insert_until_reached(session, limit=400)          # i drives along the block's long axis: +y here
    assert state["reached"] and state["path_deformation"]["O3"] > 0   # straight up through O3
    demo = session.demonstration()
    assert np.array_equal(demo.path[0], scene.start) and demo.task.goal is not None
    out = tmp_path / "planar.json"
    done = subprocess.run([sys.executable, "-m", "pliant.cli", "learn", "capture", "planar-objects", "--keys",
                           "i" * (len(demo.path) - 1), "--output", str(out)], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert load_demonstrations(out)[1][0].task.goal is not None
