"""The robots (URDF) and scenes (TOML) shipped with frcontrol, read with importlib.resources."""

__all__: list[str] = []  # data only
