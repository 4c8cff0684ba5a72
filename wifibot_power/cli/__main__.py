"""`python -m wifibot_power.cli` runs the `wbpower` command."""

from wifibot_power.cli import main

main()
