"""colcon (ament_python) entry point; the package metadata lives in pyproject.toml."""

from setuptools import setup

PACKAGE = 'exodigit_model'

setup(
    python_requires='>=3.10',
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
    ],
)
