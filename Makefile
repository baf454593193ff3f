# The two commands of the quick start: `make demo` and `make test`.  Both create .venv on first use.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: install demo robot-demo test lint bench clean

# ROS 1 from Debian's packages, for the ROS drivers (plugins/drivers/pliant_ros1) and their tests.  Installed
# when missing and when we can (root, apt); the venv sees Debian's Python packages through a .pth file appended
# after its own site-packages, so pip's packages always win.
ROS_DEBS := ros-core python3-rospy python3-genpy python3-std-msgs python3-std-srvs python3-sensor-msgs python3-trajectory-msgs
ROS_STAMP := $(VENV)/.ros

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

$(ROS_STAMP): $(STAMP)
	@if ! command -v rosmaster >/dev/null 2>&1 || [ ! -d /usr/lib/python3/dist-packages/rospy ] || [ ! -d /usr/lib/python3/dist-packages/trajectory_msgs ] || [ ! -d /usr/lib/python3/dist-packages/std_srvs ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing ROS 1 from Debian: $(ROS_DEBS)"; \
	    (apt-get install -y --no-install-recommends $(ROS_DEBS) >/dev/null 2>&1 || \
	     (apt-get update -qq >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
	      --no-install-recommends $(ROS_DEBS) >/dev/null)) || echo "could not install ROS 1; its driver tests skip"; \
	  else echo "ROS 1 is missing and cannot be installed here (not root or no apt); its driver tests skip"; fi; \
	fi
	@if [ -d /usr/lib/python3/dist-packages/rospy ]; then \
	  $(BIN)/python -c "import site, pathlib; pathlib.Path(site.getsitepackages()[0], 'zz_debian_ros.pth').write_text('/usr/lib/python3/dist-packages\n')"; fi
	touch $(ROS_STAMP)

# ROS 2 from pip, for the ROS 2 drivers (plugins/drivers/pliant_ros2) and their tests: the wheels of the `ros2` extra,
# under .venv/ros2 (pip install --prefix), not in the venv's site-packages: their std_msgs / sensor_msgs would shadow
# ROS 1's, and their ros_wheels_bootstrapper.pth would re-execute every Python of the venv.  The plugin runs its ROS 2
# nodes in child processes with the library path set (docs/plugins/ros2.md).  A failed download: its tests skip.
ROS2_WHEELS := ros-rclpy ros-rmw-fastrtps-cpp ros-std-msgs ros-sensor-msgs ros-trajectory-msgs ros-builtin-interfaces
ROS2_STAMP := $(VENV)/.ros2

$(ROS2_STAMP): $(STAMP)
	@$(BIN)/python -m pip install --quiet --prefix $(VENV)/ros2 --no-warn-script-location $(ROS2_WHEELS) || \
	  echo "could not install the ROS 2 wheels; the ROS 2 driver tests skip"
	touch $(ROS2_STAMP)

# Headless Chromium from Debian's packages, for the 3-D viewer's real-browser test and benchmark
# (plugins/reports/pliant_viewer; selenium drives Debian's chromedriver, nothing is downloaded).  Installed when
# missing and when we can (root, apt); otherwise that test skips, saying why.
CHROMIUM_DEBS := chromium chromium-driver
CHROMIUM_STAMP := $(VENV)/.chromium

$(CHROMIUM_STAMP): $(STAMP)
	@if [ ! -x /usr/bin/chromium ] || [ ! -x /usr/bin/chromedriver ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing headless Chromium from Debian: $(CHROMIUM_DEBS)"; \
	    (apt-get install -y --no-install-recommends $(CHROMIUM_DEBS) >/dev/null 2>&1 || \
	     (apt-get update -qq >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
	      --no-install-recommends $(CHROMIUM_DEBS) >/dev/null)) || echo "could not install Chromium; the viewer's browser test skips"; \
	  else echo "Chromium is missing and cannot be installed here (not root or no apt); the viewer's browser test skips"; fi; \
	fi
	touch $(CHROMIUM_STAMP)

# Every component's example run once (pliant plugins --check): the conformance kit on each, and their numba kernels
# compiled into numba's cache in one process.  Otherwise every process of the first run that needs a kernel compiles
# it: both test workers, their pools and the commands they start.  A kernel whose source changes later is compiled
# again on its first use.
CHECK_STAMP := $(VENV)/.checked

$(CHECK_STAMP): $(STAMP) $(ROS_STAMP) $(ROS2_STAMP)
	@echo "checking every component and compiling its kernels (pliant plugins --check, about a minute) ..."
	@$(BIN)/pliant plugins --check > $(VENV)/plugins-check.log 2>&1 || { tail -40 $(VENV)/plugins-check.log; exit 1; }
	touch $(CHECK_STAMP)

# (after CHECK_STAMP's definition: make expands a rule's prerequisites when it reads the rule)
install: $(STAMP) $(ROS_STAMP) $(ROS2_STAMP) $(CHROMIUM_STAMP) $(CHECK_STAMP)

demo: $(STAMP) $(ROS_STAMP) $(CHECK_STAMP)
	$(BIN)/pliant run demo
	@echo "open out/demo/report.md"

# A policy executed on a robot: iiwa-policy through the iiwa-ros driver on an iiwa peer (a ROS 1
# node moving the arm in pybullet), with a ROS master on loopback; report in out/iiwa-policy-on-iiwa-ros/.
# Baxter: .venv/bin/pliant robot ros-demo baxter-policy (20 belief iterations: it plans for minutes).
# It plans 20 belief iterations (max_time 1200 s is only a cap), so the plan is the same under any load (planning
# took 480-719 s on two cores at load 10-22; the whole run 949 s and exit 0 at load 14-22): docs/plugins/ros1.md.
robot-demo: $(STAMP) $(ROS_STAMP)
	$(BIN)/pliant robot ros-demo iiwa-policy

lint: $(STAMP) $(ROS_STAMP) $(ROS2_STAMP) $(CHROMIUM_STAMP) $(CHECK_STAMP)
	$(BIN)/ruff check .
	$(BIN)/lint-imports

# The suite in two phases, side by side (tests/run_phases.py).  The real-time tests (drivers and their peers,
# watchdogs, the browser) run one at a time at normal priority; everything else at the same time on TEST_WORKERS
# processes (pytest-xdist) at nice 19, so that they only take the CPU the real-time tests leave: no other test's
# load starves a peer's loop or a watchdog (tests/conftest.py; docs/testing.md has the markers and the measured
# times).  Tests that share a ROS master or a module's fixtures stay on one worker.
TEST_WORKERS ?= 2
# Python caches compiled modules (and pytest its rewritten test modules) in __pycache__ even where the environment
# says not to: the suite starts hundreds of Python processes (workers, CLI runs, peers), each compiling otherwise.
test: export PYTHONDONTWRITEBYTECODE :=
test: lint
	$(BIN)/python tests/run_phases.py --workers $(TEST_WORKERS)

bench: $(STAMP) $(ROS_STAMP) $(CHROMIUM_STAMP)
	$(BIN)/python -m pip install --quiet -e ".[bench]"   # the peers (OMPL) the benchmarks compare against
	$(BIN)/pliant bench

clean:
	rm -rf $(VENV) out build *.egg-info
