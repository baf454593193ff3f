"""``pliant robot ros2-graph [NAME]``: what a ROS 2 driver finds on the graph, without commanding anything.

Starts the driver's node (:meth:`~pliant_ros2.driver.Ros2ControlDriver.start_node`), listens to the joint states for
``duration`` s, and prints the controllers' topics (types, publishers, subscribers), the joint names the states
carry against the driver's, and the measured state rate.  ``pliant robot check NAME`` (``pliant driver NAME
--check``) then checks the states against the limits, as for every driver.
"""

from __future__ import annotations

import time


def inspect_graph(driver, duration: float = 1.0) -> dict:
    """The graph, the driver's topics with their counts, the state names and rate (``driver`` not yet open)."""
    driver.start_node()
    try:
        # discovery takes a moment: wait until the state topic has a publisher (or the duration ends), then listen
        deadline = time.monotonic() + max(duration, driver.options.connect_timeout)
        while driver.latest_state() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        first = driver.latest_state()
        time.sleep(duration)
        last = driver.latest_state()
        graph = driver.graph()
    finally:
        driver.shutdown()
    rate = None
    if first is not None and last is not None and last.received > first.received:
        rate = (last.sequence - first.sequence) / (last.received - first.received)
    topics = driver.topics
    return {"topics": {kind: {"name": name, **graph["topics"].get(name, {"types": [], "publishers": 0,
                                                                          "subscribers": 0})}
                       for kind, name in topics.items()},
            "state_names": list(last.names) if last is not None else None, "state_rate": rate,
            "controllers": sorted({name.rsplit("/", 2)[-2] for name in graph["topics"]
                                   if name.endswith(("/commands", "/joint_trajectory"))}),
            "nodes": graph["nodes"], "domain_id": driver.options.domain_id}


def run(name: str, settings: list[str], duration: float) -> int:
    """``pliant robot ros2-graph``: create the driver ``name`` with the ``--set`` ``settings``, look at the graph for
    ``duration`` s and print what it finds; returns 0 when the joint names match, 1 without a joint state, 2 when
    the states miss a joint."""
    from pliant.api import parse_override, registry

    options = dict(parse_override(text, "--set") for text in settings)
    driver = registry.default_registry().create("driver", name, source="--set", **options)
    report = inspect_graph(driver, duration)
    print(f"{name} on ROS domain {report['domain_id']}: nodes {', '.join(report['nodes']) or 'none'}")
    print(f"controllers with command topics: {', '.join(report['controllers']) or 'none'}")
    for kind, t in report["topics"].items():
        print(f"  {kind:<10} {t['name']}  [{', '.join(t['types']) or 'not on the graph'}]  "
              f"{t['publishers']} publisher(s), {t['subscribers']} subscriber(s)")
    expected = list(driver.joint_names())
    names = report["state_names"]
    if names is None:
        print(f"no joint state on {report['topics']['state']['name']} within the wait")
        return 1
    rate = report["state_rate"]
    to_ros = dict(zip(expected, driver.options.joints))
    print(f"joint states at {rate:.1f} Hz" if rate is not None else "joint states: one message only",
          "naming " + ", ".join(to_ros.get(n, n) for n in names))
    missing = [j for j in expected if j not in names]
    if missing:
        print(f"error: the states do not name {', '.join(missing)} (joints option: {', '.join(driver.options.joints)})")
        return 2
    print("ok: the controllers' topics and the joint names match; pliant robot check " + name +
          " checks the states against the limits")
    return 0
