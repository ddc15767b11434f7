"""The motion architecture: typed elements, the document and its checks, dynamics, learners, the builder."""
