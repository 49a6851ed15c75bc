"""Optional dependencies: imported when a method needs them, with an error
that says what to install."""

import importlib
from types import ModuleType

# module → (pip package, the extra of quaketwin that brings it)
_PACKAGES = {
    "numpy": ("numpy", "numpy"),
    "matplotlib": ("matplotlib", "plot"),
    "matplotlib.pyplot": ("matplotlib", "plot"),
    "obspy": ("obspy", "obspy"),
    "fsspec": ("fsspec", "fleet"),
    "distributed": ("dask[distributed]", "fleet"),
}


def need(module: str, purpose: str) -> ModuleType:
    """``module`` imported, or ``ModuleNotFoundError`` saying that
    ``purpose`` needs it and how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        package, extra = _PACKAGES.get(module, (module.split(".")[0], None))
        hint = f"pip install {package}"
        if extra is not None:
            hint += f" (or pip install 'quaketwin[{extra}]')"
        raise ModuleNotFoundError(
            f"{purpose} needs {package}, which is not installed: {hint}", name=package
        ) from e
