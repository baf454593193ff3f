"""The three ROS 1 transports against their robot peers on a real master on loopback: registration and options,
connecting and reading state (joint names from the URDFs; Baxter's arm among both arms, head and torso; the iiwa's
unnamed axes), the conformance kit, a missing master in one line, and no socket beyond loopback."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from pliant import registry
from pliant.errors import ConfigError, ConnectionLost, RobotDisabled
from pliant.testing import check_driver
from pliant_ros1.robots import BAXTER_STATE_JOINTS, arm_joints, state_joints
from ros1_helpers import HAVE_ROSPY, need_ros, reachable_target, wait_until

pytestmark = pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning")

DRIVERS = {"pr2": "pr2-ros", "baxter": "baxter-ros", "iiwa": "iiwa-ros"}
ARMS = [("baxter", "right"), ("baxter", "left"), ("pr2", "right"), ("pr2", "left"), ("iiwa", "right")]


def test_the_drivers_are_registered_with_documented_options(monkeypatch):
    assert {"pr2-ros", "baxter-ros", "iiwa-ros"} <= set(registry.available("driver"))
    monkeypatch.setenv("ROS_MASTER_URI", "http://127.0.0.1:22422")
    baxter = registry.create("driver", "baxter-ros", side="left")
    assert baxter.options.master_uri == "http://127.0.0.1:22422"          # default from the environment
    assert baxter.joint_names() == arm_joints("baxter", "left")
    assert baxter.limits.command_timeout == 0.2 and baxter.options.speed_ratio == 1.0
    monkeypatch.delenv("ROS_MASTER_URI")
    pr2 = registry.create("driver", "pr2-ros")
    assert pr2.options.master_uri == "http://127.0.0.1:11311" and pr2.joint_names()[0] == "r_shoulder_pan_joint"
    iiwa = registry.create("driver", "iiwa-ros", speed_scale=0.5)
    assert iiwa.limits.velocity[0] == pytest.approx(0.5 * np.radians(98))
    with pytest.raises(ConfigError, match=r"driver\.side: must be one of right, left"):
        registry.create("driver", "baxter-ros", side="centre")
    with pytest.raises(ConfigError, match=r"driver\.speed_ratio: must be <= 1"):
        registry.create("driver", "baxter-ros", speed_ratio=1.5)
    with pytest.raises(ConfigError, match="unknown option"):
        registry.create("driver", "iiwa-ros", side="left")                # the iiwa has one arm
    assert baxter.latest_state() is None and baxter.robot_status().detail == "not connected"
    with pytest.raises(ConnectionLost, match="not connected"):
        baxter.write(np.zeros(7), np.zeros(7))


def test_the_plugin_entry_point_and_the_registry_import_no_ros():
    code = ("import sys, pliant; from pliant import registry; names = registry.available('driver'); "
            "import pliant_ros1.plugin; assert {'pr2-ros', 'baxter-ros', 'iiwa-ros'} <= set(names), names; "
            "heavy = [m for m in ('rospy', 'genpy', 'pliant_ros1.baxter', 'pliant_ros1.driver') if m in sys.modules]; "
            "assert not heavy, heavy")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr


def test_open_without_a_master_is_one_line_connection_lost():
    need_ros()
    from pliant_ros1.master import free_port

    uri = f"http://127.0.0.1:{free_port()}"
    for name in DRIVERS.values():
        driver = registry.create("driver", name, master_uri=uri, master_timeout=0.3)
        start = time.monotonic()
        with pytest.raises(ConnectionLost) as info:
            with driver:
                pass
        assert time.monotonic() - start < 2.0
        assert str(info.value) == f"ROS master at {uri} unreachable (connection refused)"
    # the command line says the same in one line, exit status 2
    result = subprocess.run([sys.executable, "-m", "pliant.cli", "robot", "check", "baxter-ros", "--set",
                             f"master_uri={uri}"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert result.stderr.strip() == f"error: ROS master at {uri} unreachable (connection refused)"


@pytest.mark.parametrize(("robot", "side"), ARMS)
def test_each_driver_connects_to_its_peer_and_reads_the_state(robot, side, make_peer, make_driver):
    peer = make_peer(robot, side, "--enabled") if robot == "baxter" else make_peer(robot, side)
    driver = make_driver(DRIVERS[robot], **({} if robot == "iiwa" else {"side": side}))
    assert driver.joint_names() == arm_joints(robot, side)
    # the conformance kit: names, limits, states with growing stamps and counter, status, shutdown twice, stream
    assert check_driver(driver) == ["joint names", "limits", "joint states", "status", "shutdown twice", "stream",
                                    "non-finite", "closed on exit"]
    driver.open()
    try:
        assert wait_until(lambda: driver.latest_state() is not None)
        state = driver.latest_state()
        if robot == "baxter":     # both arms, the head and the torso: the core finds this arm's joints by name
            assert state.names == BAXTER_STATE_JOINTS and set(driver.joint_names()) < set(state.names)
            assert state.velocities is not None and state.velocities.shape == (17,)
            assert driver.robot_status().enabled
        elif robot == "pr2":      # every joint of the robot
            assert state.names == state_joints("pr2") and len(state.names) == 30
        else:                     # the iiwa's messages name nothing and carry no velocities
            assert state.names == driver.joint_names() and state.velocities is None
        index = [state.names.index(n) for n in driver.joint_names()]
        recorded = [r for r in peer.records() if r["kind"] == "state"]
        np.testing.assert_allclose(state.positions[index], recorded[-1]["positions"], atol=1e-6)
        first = state.sequence
        time.sleep(0.3)
        rate = (driver.latest_state().sequence - first) / 0.3
        expected = 250.0 if robot == "iiwa" else 100.0
        assert 0.6 * expected < rate < 1.4 * expected
    finally:
        driver.shutdown()


def test_baxter_starts_disabled_and_is_enabled_only_when_asked(make_peer, make_driver):
    peer = make_peer("baxter", "right")
    driver = make_driver("baxter-ros", speed_ratio=0.8)
    with pytest.raises(RobotDisabled, match="disabled"):
        driver.check()                                  # looking does not enable
    report = driver.check(enable=True)
    assert report["enabled"] and report["joints"] == list(arm_joints("baxter", "right"))
    assert 80 < report["measured_state_rate"] < 120
    events = [r["event"] for r in peer.records() if r["kind"] == "event"]
    assert any(e.startswith("enabled (set_super_enable True)") for e in events)
    assert "speed ratio 0.8" in events                  # published when connecting


def _loopback(host: str) -> bool:
    return host in ("localhost", "::1") or host.startswith("127.")


def test_a_driver_talks_to_nothing_beyond_loopback(make_peer, make_driver, monkeypatch):
    """Record every address any socket of this process connects to, and every name it resolves, while a driver
    connects, moves the arm and disconnects; all of them must be loopback.  The node's servers must listen on
    loopback only."""
    need_ros()
    peer = make_peer("baxter", "right", "--enabled", "--simulator", "none")
    connected, resolved = [], []
    real_connect, real_connect_ex, real_getaddrinfo = socket.socket.connect, socket.socket.connect_ex, \
        socket.getaddrinfo

    def connect(self, address):
        connected.append(address)
        return real_connect(self, address)

    def connect_ex(self, address):
        connected.append(address)
        return real_connect_ex(self, address)

    def getaddrinfo(host, *args, **kwargs):
        resolved.append(host)
        return real_getaddrinfo(host, *args, **kwargs)

    monkeypatch.setattr(socket.socket, "connect", connect)
    monkeypatch.setattr(socket.socket, "connect_ex", connect_ex)
    monkeypatch.setattr(socket, "getaddrinfo", getaddrinfo)
    driver = make_driver("baxter-ros")
    with driver:
        q = driver.state()
        driver.move_to(reachable_target(q, driver.limits, np.random.default_rng(3), 0.05, 0.1))
    driver.close()
    peer.stop()
    monkeypatch.undo()
    assert connected, "the driver connected to nothing?"
    hosts = {a[0] if isinstance(a, tuple) else a for a in connected}
    assert all(isinstance(h, str) and (_loopback(h) or h.startswith("/")) for h in hosts), hosts
    assert all(h is None or _loopback(str(h)) for h in resolved), set(resolved)
    import rospy

    uri = rospy.get_node_uri()
    assert uri.startswith("http://127.0.0.1:")
    port = int(uri.rstrip("/").rsplit(":", 1)[1])
    if Path("/proc/net/tcp").exists():
        listening = {line.split()[1].rsplit(":", 1)[0] for line in Path("/proc/net/tcp").read_text().splitlines()[1:]
                     if int(line.split()[1].rsplit(":", 1)[1], 16) == port and line.split()[3] == "0A"}
        assert listening == {"0100007F"}


@pytest.mark.skipif(not HAVE_ROSPY, reason="ROS 1 is not installed: no rospy (Debian: python3-rospy)")
def test_the_peer_command_line_runs_and_stops(master, tmp_path):
    """``pliant robot ros-peer`` (the pliant_commands hook) starts a peer that a driver can use, for a set time."""
    log = tmp_path / "peer.log"
    env = {**os.environ, "ROS_MASTER_URI": master.uri, "ROS_IP": "127.0.0.1"}
    with open(log, "wb") as out:
        process = subprocess.Popen([sys.executable, "-m", "pliant.cli", "robot", "ros-peer", "iiwa", "--simulator",
                                    "none", "--master", master.uri, "--duration", "3"], stdout=out,
                                   stderr=subprocess.STDOUT, env=env)
        try:
            assert wait_until(lambda: "pliant-peer ready iiwa" in log.read_text(), timeout=60), log.read_text()
            assert process.wait(30) == 0
        finally:
            if process.poll() is None:
                process.kill()


def test_the_peers_time_out_like_their_robots(make_peer, make_driver):
    """Written straight to the transport (no stream): Baxter, at speed ratio 0.1, holds 0.2 s after the last
    command, short of it; the iiwa keeps going to its last destination."""
    make_peer("baxter", "right", "--enabled", "--simulator", "none")
    baxter = make_driver("baxter-ros", speed_ratio=0.1)
    baxter.open()
    try:
        assert wait_until(lambda: baxter.latest_state() is not None)
        time.sleep(0.3)                                  # the latched speed ratio has arrived
        index = [baxter.latest_state().names.index(n) for n in baxter.joint_names()]
        q0 = baxter.latest_state().positions[index]
        goal = q0.copy()
        goal[0] += 0.3 if q0[0] < 0 else -0.3            # s0: 0.3 rad away, at most 0.15 rad/s
        baxter.write(goal, np.zeros(7))
        time.sleep(0.6)
        moved = abs(baxter.latest_state().positions[index][0] - q0[0])
        assert 0.2 * 0.15 * 0.7 < moved < 0.2 * 0.15 * 1.5 + 0.01   # it moved for the 0.2 s timeout only
    finally:
        baxter.shutdown()
    make_peer("iiwa", "right", "--simulator", "none")
    iiwa = make_driver("iiwa-ros")
    iiwa.open()
    try:
        assert wait_until(lambda: iiwa.latest_state() is not None)
        q0 = iiwa.latest_state().positions
        goal = q0 + np.where(q0 < 0, 0.2, -0.2)
        iiwa.write(goal, np.zeros(7))
        assert wait_until(lambda: np.allclose(iiwa.latest_state().positions, goal, atol=1e-5), timeout=2.0)
    finally:
        iiwa.shutdown()
