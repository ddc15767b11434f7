"""The running robot: the loop, reconfiguration, the binder, the control socket, launching."""
