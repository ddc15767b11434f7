"""Feature implementations: the plugin API, manifests and one module per kind."""
