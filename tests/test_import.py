import subprocess
import sys


def test_importing_the_model_imports_no_ros():
    code = (
        'import sys, exodigit_model; '
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in "
        "{'rclpy', 'rosidl_runtime_py', 'std_msgs', 'sensor_msgs'}); "
        'print(bad); sys.exit(1 if bad else 0)'
    )
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
