"""`python -m wifibot_power` runs the `wbpower` command (e.g. where the script is not on PATH)."""

from wifibot_power.cli import main

if __name__ == "__main__":
    main()
