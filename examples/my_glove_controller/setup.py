from setuptools import find_packages, setup

PACKAGE = 'my_glove_controller'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
    ],
    install_requires=['setuptools', 'numpy'],
    tests_require=['pytest', 'exodigit_nodes'],
    zip_safe=True,
    maintainer='you',
    maintainer_email='you@example.org',
    description='Example glove controller, tested against the exodigit simulated glove',
    license='Apache-2.0',
    entry_points={'console_scripts': [f'flex_controller = {PACKAGE}.flex_controller:main']},
)
