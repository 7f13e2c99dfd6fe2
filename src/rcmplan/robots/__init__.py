"""Robot files shipped with rcmplan (TOML, `rcmplan.robot.robot_file`), loaded by name."""
