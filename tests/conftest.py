import os
import sys
import tempfile

import pytest

# Tests use their own mesh cache so they never read a stale user cache.
os.environ.setdefault("ELASTOCELL_CACHE", os.path.join(tempfile.gettempdir(), "elastocell-test-cache"))


@pytest.fixture(autouse=True)
def _fresh_dclab_lut_registry(monkeypatch):
    """Each test starts with dclab's registry of external look-up tables empty (``EXTERNAL_LUTS``, a module global
    that ``register_lut`` fills for the whole process): a table one test registers, such as a shipped one through
    ``fit rtdc --lut <identifier>``, would otherwise make another test's registration under the same identifier a
    clash. Only when dclab is already imported: a test that imports it first finds it empty anyway."""
    load = sys.modules.get("dclab.features.emodulus.load")
    if load is not None:
        monkeypatch.setattr(load, "EXTERNAL_LUTS", {})
    yield
