"""Built-in computes (output quantities), each computed only when an output writes it. They
are registered by name in :mod:`peridyn.plugins.builtins`."""
