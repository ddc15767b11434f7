"""guidelines/running-with-ros2.md's session, replayed on a real graph: the guide's key lines stay true.

The page shows a session in several terminals: the UV robot's lifecycle nodes, `motivml run
... --ros2 --ros-namespace /uv`, and `guidelines/examples/ros2_client.py` swapping the
person detectors, refused twice, then the lamp's node killed and the fault handled. This
test runs the same commands as processes, on a ROS domain of its own on loopback, and
checks the lines the page shows (not the timestamps and ticks, which differ every run).
Every wait is for a line of a process's output or a client's answer, with a deadline.
"""

from __future__ import annotations

import queue
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

from ros2_support import ROOT, ROS2, Client, domain, environment, processes, python_process

pytestmark = ROS2

CLIENT = "guidelines/examples/ros2_client.py"
NODES = ("irradiation", "lamp", "low_intensity", "high_intensity", "person_detection", "thermal_detection")
DEADLINE = 30.0  # s: discovery, processes starting, a lifecycle node's 5 s timeout on the way

XOR_REFUSAL = (
    "refused: camera_person_detection and thermal_presence_detection are alternatives in human_detection's "
    "XOR group, but camera_person_detection would be active and thermal_presence_detection would be active"
)
STATIC_REFUSAL = (
    "refused: platform_control is bound Static Early: a Static feature never unloads or reloads; it is compiled "
    "in (section 4)"
)
# A node killed a moment ago may still be on the graph (DDS forgets it when its lease ends):
# then it is there but does not answer (and nothing has moved: it is asked before anything).
LAMP_MISSING = (
    r"refused: cannot start uv_lamp_control: node /uv/lamp "
    r"(is not on the ROS graph: no /uv/lamp/change_state|did not answer get_state) within 5 s\n"
)


class Output:
    """A process's output, line by line, read on a thread of its own."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        self.lines: queue.SimpleQueue[str] = queue.SimpleQueue()
        self.seen: list[str] = []
        assert process.stdout is not None
        self._thread = threading.Thread(target=self._read, args=(process.stdout,), daemon=True)
        self._thread.start()

    def _read(self, stream: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            self.lines.put(line.rstrip("\n"))

    def expect_all(self, *patterns: str, timeout: float = DEADLINE) -> None:
        """Lines from now on that match every pattern, in any order (the run's own log and
        rosout are written by different threads)."""
        left = list(patterns)
        deadline = time.monotonic() + timeout
        while left:
            line = self.expect("|".join(f"(?:{p})" for p in left), max(deadline - time.monotonic(), 0.0)).string
            left = [p for p in left if not re.search(p, line)]

    def expect(self, pattern: str, timeout: float = DEADLINE) -> re.Match[str]:
        """The first line from now on that matches `pattern` (a regular expression)."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            try:
                line = self.lines.get(timeout=max(left, 0.0))
            except queue.Empty:
                raise AssertionError(
                    f"no line matching {pattern!r} within {timeout} s; output so far:\n"
                    + "\n".join(self.seen)
                ) from None
            self.seen.append(line)
            found = re.search(pattern, line)
            if found:
                return found


def client(domain_id: int, *args: str) -> tuple[int, str]:
    """The guide's client, as the guide runs it: exit code, and stdout and stderr together."""
    done = subprocess.run(  # noqa: S603 (our own interpreter and script)
        [sys.executable, CLIENT, "--namespace", "/uv", *args],
        env=environment(domain_id),
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        timeout=DEADLINE + 40,
    )
    return done.returncode, done.stdout


def until_client(domain_id: int, args: list[str], wanted: str, timeout: float = DEADLINE) -> str:
    """Ask with the client until its output contains `wanted` (the parameters follow a
    fault's unload just after the run logs it)."""
    deadline = time.monotonic() + timeout
    while True:
        code, text = client(domain_id, *args)
        if code == 0 and wanted in text:
            return text
        if time.monotonic() > deadline:
            raise AssertionError(f"the client never printed {wanted!r}; last:\n{text}")


def start_node(domain_id: int, name: str, params: Path) -> subprocess.Popen[str]:
    return python_process(
        ["plugins/ros2/uv_nodes.py", name, "--ros-args", "-r", "__ns:=/uv", "--params-file", str(params)],
        domain_id,
    )


def wait_for_nodes(domain_id: int, names: tuple[str, ...]) -> None:
    """Until every node answers on its lifecycle services (so the run finds them at once)."""
    probe = Client(domain_id, "/uv")
    try:
        for name in names:
            assert probe.state(name), f"node /uv/{name} did not come up"
    finally:
        probe.close()


def test_the_guides_session(tmp_path: Path) -> None:
    configure = subprocess.run(  # noqa: S603
        [sys.executable, "-m", "motivml.cli", "configure", "feature_models/uv_disinfection", "--variant", "ros2_ward",
         "-o", str(tmp_path / "ward")],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )  # fmt: skip
    assert configure.returncode == 0, configure.stdout + configure.stderr
    params = tmp_path / "ward" / "ros2_params.yaml"

    domain_id = domain()
    with processes() as started:
        nodes = {name: start_node(domain_id, name, params) for name in NODES}
        started.extend(nodes.values())
        wait_for_nodes(domain_id, NODES)
        run = python_process(
            ["-m", "motivml.cli", "run", "feature_models/uv_disinfection", "--variant", "ros2_ward", "--ros2",
             "--ros-namespace", "/uv", "--duration", "inf", "--no-live", "--run-dir", str(tmp_path / "run")],
            domain_id,
        )  # fmt: skip
        started.append(run)
        out = Output(run)
        out.expect(r"^ROS 2: node /uv/motivml \(features\.<id>\.active parameters\)$")

        code, text = client(domain_id)
        assert code == 0, text
        assert "camera_person_detection" in text.splitlines()[0] and "since tick 0: the start" in text

        # The swap: both detectors in one atomic call.
        assert client(domain_id, "camera_person_detection=false", "thermal_presence_detection=true") == (
            0,
            "accepted\n",
        )
        out.expect_all(
            r"\[uv\.motivml\]: accepted set \+thermal_presence_detection -camera_person_detection: "
            r"loaded thermal_presence_detection; unloaded camera_person_detection$",
            r"^\d\d:\d\d:\d\d\.\d{3} tick \d+: set \+thermal_presence_detection -camera_person_detection$",
        )

        # Two refusals, with their reasons; nothing changes.
        code, text = client(domain_id, "camera_person_detection=true")
        assert code == 1 and text.startswith(XOR_REFUSAL), text
        out.expect(
            r"^at [\d.]+ s \(tick \d+\): refused set \+camera_person_detection: camera_person_detection and"
        )
        assert client(domain_id, "platform_control=false") == (1, STATIC_REFUSAL + "\n")
        out.expect_all(
            r"\[uv\.motivml\]: refused set -platform_control: platform_control is bound",
            r"^at [\d.]+ s \(tick \d+\): refused set -platform_control: platform_control is bound",
        )

        # The lamp's node dies: a fault of uv_lamp_control, which cannot leave alone (it is
        # irradiation's mandatory sub-feature), so irradiation is unloaded with its subtree.
        nodes["lamp"].kill()
        nodes["lamp"].wait(timeout=DEADLINE)
        out.expect(r"^at [\d.]+ s \(tick \d+\): uv_lamp_control raised in step: node /uv/lamp "
                   r"stopped answering \(no state within 0\.8 s\): it died or hung$")  # fmt: skip
        out.expect(r"^at [\d.]+ s \(tick \d+\): unloaded irradiation after the fault of uv_lamp_control$")
        # the tries that led there (uv_lamp_control alone) are not news: no refusal is logged
        assert not [line for line in out.seen if "refused unload" in line], out.seen
        parameters = until_client(domain_id, ["--parameters"], "features.irradiation.active: false")
        for line in (
            "features.thermal_presence_detection.active: true",
            "features.irradiation.active: false",
            "features.uv_lamp_control.active: false",
            "features.low_intensity.active: false",
            "features.spraying.active: true",
        ):
            assert line in parameters.splitlines(), parameters
        code, text = client(domain_id)
        assert code == 0 and text.splitlines()[1].endswith(
            ": unload irradiation (after the fault of uv_lamp_control)"
        ), text
        assert "irradiation" not in text.splitlines()[0], text

        # The run goes on: irradiation comes back once its lamp is back.
        code, text = client(domain_id, "irradiation=true", "low_intensity=true")
        assert code == 1 and re.fullmatch(LAMP_MISSING, text), text
        nodes["lamp"] = start_node(domain_id, "lamp", params)
        started.append(nodes["lamp"])
        wait_for_nodes(domain_id, ("lamp",))
        assert client(domain_id, "irradiation=true", "low_intensity=true") == (0, "accepted\n")
        out.expect(r"\[uv\.motivml\]: accepted set \+irradiation \+low_intensity: "
                   r"loaded irradiation, uv_lamp_control, low_intensity$")  # fmt: skip

        run.terminate()
        assert run.wait(timeout=DEADLINE) == 0
        out.expect(r"^changed at [\d.]+ s \(tick \d+\): set \+irradiation \+low_intensity$")


def test_the_client_says_when_no_motivml_node_answers_and_checks_its_arguments() -> None:
    domain_id = domain()
    code, text = client(domain_id, "--timeout", "1", "irradiation=true")
    assert code == 3, text
    assert text == (
        "ros2_client.py: nothing answered on /uv/motivml/set_parameters_atomically within 1 s: no motivml node "
        f"/uv/motivml on ROS_DOMAIN_ID {domain_id} (is `motivml run ... --ros2 --ros-namespace /uv` running, "
        "with the same ROS_DOMAIN_ID?)\n"
    )
    code, text = client(domain_id, "irradiation=yes")
    assert code == 2 and "write FEATURE=true or FEATURE=false" in text, text
    code, text = client(domain_id, "--parameters", "irradiation=true")
    assert code == 2 and "--parameters prints; it takes no FEATURE=VALUE" in text, text
