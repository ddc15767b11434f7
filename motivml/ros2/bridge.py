"""The ROS 2 bridge process (`python -m motivml.ros2`): rclpy, for one run and one namespace.

Started by the run (`motivml.plugins.bridge.Bridge`) with one end of a socket pair; see
there for why it is a process of its own. It answers the run's calls:

* `lifecycle`: one move of a ros2_lifecycle plugin's node (`motivml.ros2.lifecycle`);
* `door`, `door_close`: start and end the `motivml` node (`motivml.ros2.node`);
* `exit`: end, once every node is cleaned up.

and passes the run's news (`outcome`, `health`) to the node. Calls run on one worker
thread, in the order they came (a node's moves on the link's own thread: the run waits for
each); news goes to the node as it arrives (an outcome is queued there for the node's own
thread, `motivml.ros2.node`). When the run's end of the
link closes without an `exit` (the run was killed), every node the run had moved out of
unconfigured (activated, or configured for a load never committed) is moved back there
before the bridge ends.
"""

from __future__ import annotations

import argparse
import signal
import socket
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from ..errors import EnvironmentProblem, describe_exception
from ..plugins.bridge import Link, LinkBroken
from .graph import Graph
from .lifecycle import LifecycleNodes
from .node import FrontDoor

EXIT_ENVIRONMENT = 3
SWITCH_INTERVAL = 0.0001  # s (the loop's own, see runtime/loop.py)


class Server:
    def __init__(self, asking: socket.socket, hearing: socket.socket, ns: str) -> None:
        self.namespace = ns
        self.ended = threading.Event()
        self.asked_to_exit = False
        self.graph: Graph | None = None
        self.nodes: LifecycleNodes | None = None
        self.door: FrontDoor | None = None
        self.worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="motivml-bridge")
        self.link = Link(asking, hearing, self.handle, self.closed, "run")

    def tell(self, message: dict[str, Any]) -> None:
        try:
            self.link.send(message)
        except LinkBroken:
            pass

    def handle(self, message: dict[str, Any]) -> None:
        """On the link's thread: calls go to the worker, news to the node."""
        kind = message.get("op") or message.get("event")
        if kind == "exit":
            self.asked_to_exit = True
            self.ended.set()
        elif kind == "lifecycle":
            # Right here: the run sends one move at a time and waits for it (a thread hop
            # less on a swap's way); the node's answers come on its executor's thread.
            self.serve(message)
        elif kind in ("door", "door_close"):
            self.worker.submit(self.serve, message)
        elif kind == "outcome" and self.door is not None:
            self.door.heard(message)
        elif kind == "health" and self.door is not None:
            self.door.publish_health(message)

    def serve(self, message: dict[str, Any]) -> None:
        try:
            answer = self.answer(message)
        except Exception as exc:  # a bug of ours: the call that met it is answered with it
            answer = {"error": f"the ROS 2 bridge failed: {describe_exception(exc)}"}
        if "id" in message:
            self.link.answer(message, **answer)
        elif "error" in answer:  # a move nobody waits for (a clean-up): its failure goes to the log
            self.tell({"event": "log", "feature": message.get("feature", ""), "text": answer["error"]})

    def answer(self, message: dict[str, Any]) -> dict[str, Any]:
        assert self.graph is not None and self.nodes is not None
        op = message["op"]
        if op == "lifecycle":
            return self.nodes.handle(message)
        if op == "door":
            if self.door is not None:
                return {"error": f"the node {self.door.name} runs already"}
            self.door = FrontDoor(self.graph, self.link, message)
            return {"name": self.door.name}
        door, self.door = self.door, None  # door_close
        if door is not None:
            door.close()
        return {}

    def closed(self, reason: str) -> None:
        self.ended.set()

    def run(self) -> int:
        try:
            self.graph = Graph(self.namespace)
        except EnvironmentProblem as failed:
            first = failed.diagnostics[0]
            self.tell({"event": "failed", "message": first.message, "code": first.rule})
            self.link.close()
            return EXIT_ENVIRONMENT
        self.nodes = LifecycleNodes(self.graph, self.tell)
        self.tell({"event": "ready"})
        self.ended.wait()
        self.worker.shutdown(wait=True)  # the call under way ends (a node's timeout at most)
        if self.door is not None:
            self.door.close()
        if not self.asked_to_exit:  # the run went without ending its features
            # The link broke, maybe on another thread's write (a log line, an answer) while
            # the link's thread still moves a node: that move ends first (within its
            # node's timeout), or a node it starts would be configured after the release.
            self.link.join_reader()
            self.nodes.release_all()
        self.nodes.close()
        self.graph.close()
        self.link.close()
        return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m motivml.ros2", description=__doc__.splitlines()[0])
    parser.add_argument("--fds", required=True, help="this process's ends of the run's socket pairs: ASKING,HEARING")
    parser.add_argument("--namespace", default="/")
    # The run has the terminal's Ctrl-C (the bridge has a process group of its own, but a
    # shell may signal it anyway): it ends the bridge through the link. And the bridge's
    # log lines go on to the terminal even where `stty tostop` stops a background group
    # that writes to it.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTTOU, signal.SIG_IGN)
    args = parser.parse_args(argv)
    # An answer passes from the thread that heard it (an executor's, the link's) to the one
    # that waits for it: with Python's default 5 ms switch interval, a thread running on
    # (an executor building its next wait set) keeps the waiting one waiting that long.
    sys.setswitchinterval(SWITCH_INTERVAL)
    asking, hearing = (socket.socket(fileno=int(fd)) for fd in args.fds.split(","))
    return Server(asking, hearing, args.namespace).run()


if __name__ == "__main__":  # pragma: no cover (run as python -m motivml.ros2)
    sys.exit(main())
