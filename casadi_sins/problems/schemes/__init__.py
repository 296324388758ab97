"""Shipped rotation schemes of ``casadi-sins modulate`` (``format = "casadi-sins-scheme/1"``), one TOML file each."""
