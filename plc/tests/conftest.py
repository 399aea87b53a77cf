import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def pytest_configure(config):
    config.addinivalue_line("markers", "cell(**kwargs): arguments of the test's Cell (hans-sim, hans-gateway)")
