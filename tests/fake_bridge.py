"""A scripted ROS 2 bridge for tests/test_bridge.py: `python -m fake_bridge --fds A,H --namespace NS`.

It speaks the bridge's side of the link (motivml/ros2/bridge.py) without rclpy, so that the
run's side (motivml.plugins.bridge.Bridge, motivml.ros2.door.Door) can be tested in the
default .venv. The namespace picks what it does:

* `/silent`: never says it is ready (it waits until the run kills it);
* `/mute`: ends at once, exit code 5, without a word;
* `/refusing`: ready, but answers `door` with an error;
* `/stubborn`: ready, and takes no `exit`;
* `/fragile`: ready, and ends (exit code 7) when asked for the `door`;
* anything else: ready, and serves:
  - `door` (remembered), `door_close`: answered as the real bridge does;
  - `echo`: answered with the call's own fields;
  - `ask`: calls the run with `kind` and `fields` and answers with the run's answer;
  - `tell`: sends the run the one-way message `message`;
  - `heard`: answered with the `door` call and every one-way message received so far;
  - `affinity`: answered with the CPUs this process may run on;
  - `die`: ends at once, exit code 7.
"""

from __future__ import annotations

import argparse
import os
import socket
import sys
import threading
from typing import Any

from motivml.plugins.bridge import Link


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--fds", required=True)
    parser.add_argument("--namespace", required=True)
    args = parser.parse_args()
    ns = args.namespace
    if ns == "/mute":
        return 5
    asking, hearing = (socket.socket(fileno=int(fd)) for fd in args.fds.split(","))
    ended = threading.Event()
    heard: list[dict[str, Any]] = []
    link: Link

    def handle(message: dict[str, Any]) -> None:
        op = message.get("op")
        if op is None:
            heard.append(message)
        elif op == "exit":
            if ns != "/stubborn":
                ended.set()
        elif op == "door":
            heard.append(message)
            if ns == "/fragile":
                os._exit(7)
            if ns == "/refusing":
                link.answer(message, error="the node /refusing/motivml runs already")
            else:
                link.answer(message, name=f"{ns.rstrip('/')}/motivml")
        elif op == "door_close":
            link.answer(message)
        elif op == "echo":
            link.answer(message, **{k: v for k, v in message.items() if k not in ("op", "id")})
        elif op == "ask":
            link.answer(message, answer=link.call(message["kind"], 10.0, **message.get("fields", {})))
        elif op == "tell":
            link.send(message["message"])
            link.answer(message)
        elif op == "heard":
            link.answer(message, heard=heard)
        elif op == "affinity":
            link.answer(message, cpus=sorted(os.sched_getaffinity(0)))
        elif op == "die":
            os._exit(7)

    link = Link(asking, hearing, handle, lambda reason: ended.set(), "run")
    if ns != "/silent":
        link.send({"event": "ready"})
    ended.wait()
    link.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
