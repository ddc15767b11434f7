"""rclpy in the bridge process: a context of its own, and nodes spinning on threads of their own."""

from __future__ import annotations

import threading
from typing import Any

from ..errors import EnvironmentProblem, Location, describe_exception, error

INSTALL_HINT = (
    "install ROS 2's Python packages: make ros2, then use .venv-ros/bin/motivml "
    "(or pip install 'motivml[ros2]')"
)


def import_rclpy() -> Any:
    """rclpy, or EnvironmentProblem (exit 3) saying how to install it."""
    try:
        import rclpy
    except ImportError as exc:
        raise EnvironmentProblem(
            error(Location("ros2"), f"ROS 2 is not available in this Python ({exc}): {INSTALL_HINT}", "ros2.missing")
        ) from None
    return rclpy


class Graph:
    """The bridge's rclpy: a context, the node `motivml_binder` that drives lifecycle nodes,
    and a way to spin nodes.

    Each node spins on an executor of its own, on a thread of its own (`spin`): the lifecycle
    clients never wait behind a service callback of the front door (which itself waits for
    lifecycle transitions), and a single-threaded executor answers a client sooner than a
    pool of threads handing work to each other under the GIL.
    """

    def __init__(self, ns: str) -> None:
        rclpy = import_rclpy()

        self.namespace = ns
        self.context = rclpy.Context()
        self._spinning: list[tuple[Any, Any, threading.Thread]] = []  # (node, executor, thread)
        try:
            rclpy.init(context=self.context)  # ROS_DOMAIN_ID and the rest from the environment
            self.node = rclpy.create_node(
                "motivml_binder",
                namespace=ns,
                context=self.context,
                start_parameter_services=False,
            )
            self.spin(self.node)
        except Exception as exc:  # rclpy's RCLError: a bad ROS_DOMAIN_ID, say
            self.context.try_shutdown()
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise EnvironmentProblem(
                error(Location("ros2"), f"ROS 2 could not start: {first}", "ros2.start")
            ) from None

    def spin(self, node: Any) -> None:
        """Spin `node` on an executor and a daemon thread of its own until `forget` or `close`."""
        from rclpy.executors import SingleThreadedExecutor

        executor = SingleThreadedExecutor(context=self.context)
        executor.add_node(node)

        def spin() -> None:
            # A callback that raises ends rclpy's spin: log it and spin on, so that one bad
            # message never silences the node. The context shutting down ends it for good.
            while self.context.ok():
                try:
                    executor.spin()
                    return
                except Exception as exc:
                    if not self.context.ok():
                        return
                    node.get_logger().error(f"a callback raised {describe_exception(exc)}; spinning on")
                except BaseException:  # (rclpy's shutdown exceptions, a KeyboardInterrupt)
                    return

        thread = threading.Thread(target=spin, daemon=True, name=f"motivml-ros2-{node.get_name()}")
        thread.start()
        self._spinning.append((node, executor, thread))

    def forget(self, node: Any) -> None:
        """Stop spinning `node` and destroy it."""
        self.stop(node)
        node.destroy_node()

    def stop(self, node: Any) -> None:
        """Stop spinning `node` (its callbacks have ended when this returns)."""
        for entry in list(self._spinning):
            if entry[0] is node:
                self._spinning.remove(entry)
                _, executor, thread = entry
                executor.shutdown(timeout_sec=2.0)
                thread.join(timeout=2.0)

    def call(self, client: Any, request: Any, timeout: float) -> Any:
        """A service call from any thread but the executor's; None when no answer came in time."""
        return self.answer(client, self.send(client, request), timeout)

    def send(self, client: Any, request: Any) -> tuple[Any, threading.Event]:
        """Send a request; `answer` waits for it."""
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        return future, done

    def answer(self, client: Any, sent: tuple[Any, threading.Event], timeout: float) -> Any:
        future, done = sent
        if not done.wait(timeout):
            client.remove_pending_request(future)
            return None
        return future.result()

    def close(self) -> None:
        for node, _, _ in list(self._spinning):
            self.forget(node)
        self.context.try_shutdown()
