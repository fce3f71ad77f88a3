import os
import tempfile

# Tests use their own mesh cache so they never read a stale user cache.
os.environ.setdefault("ELASTOCELL_CACHE", os.path.join(tempfile.gettempdir(), "elastocell-test-cache"))
