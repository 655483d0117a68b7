"""ament_python package of the exodigit ROS 2 nodes (colcon build, or pip install)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'exodigit_nodes'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    # The Fast DDS profile every process of the package names (exodigit_nodes/nodes/dds.py),
    # and the testing kit's for a target run (exodigit_nodes/testing/target_run.py).
    package_data={f'{PACKAGE}.nodes': ['fastdds.xml']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/launch', glob('launch/*.launch.py')),
        (f'share/{PACKAGE}/config', glob('config/*.yaml')),
        (f'share/{PACKAGE}/config/hand', glob('config/hand/*.yaml')),
    ],
    # matplotlib: the runner's session plot; rosbags: the recorder's bag (pip only, see
    # package.xml); pyserial and cobs: the hardware bridge's serial link (docs/spec/hardware.md)
    install_requires=[
        'setuptools',
        'exodigit_model',
        'numpy',
        'PyYAML>=6',
        'matplotlib>=3.7',
        'rosbags>=0.10',
        'pyserial>=3.5',
        'cobs>=1.2',
    ],
    zip_safe=True,
    maintainer='exodigit developers',
    maintainer_email='exodigit@example.org',
    description='ROS 2 nodes of the exodigit simulated soft rehabilitation glove',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            f'plant = {PACKAGE}.console:plant',
            f'pressure_command = {PACKAGE}.console:pressure_command',
            f'estimator = {PACKAGE}.console:estimator',
            f'glove = {PACKAGE}.console:glove',
            f'hand = {PACKAGE}.console:hand',
            f'hand_nodes = {PACKAGE}.console:hand_nodes',
            f'recorder = {PACKAGE}.console:recorder',
            f'hardware = {PACKAGE}.console:hardware',
            f'mcu_emulator = {PACKAGE}.console:mcu_emulator',
        ],
        # The testing kit's glove_sim fixture, for every pytest run where the package is installed.
        'pytest11': [f'exodigit_glove_sim = {PACKAGE}.testing.plugin'],
    },
)
