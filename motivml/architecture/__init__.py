"""The motion architecture: its document, checks, dynamical systems, learners and the builder."""
