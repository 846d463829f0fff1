"""The mutation targets of tests/mutation/run.py: name → (source files or folders, the tests
that exercise them, cosmic-ray's per-mutant time limit in s — the runner's own limit, three
times the unmutated run, usually comes first)."""

TARGETS = {
    "safety": (["rtctl/safety"], "tests/safety", 240),
    "timing": (["rtctl/timing"], "tests/timing", 180),
    "busload": (["rtctl/busload.py"], "tests/can/test_busload.py tests/can/test_busload_survivors.py", 180),
    # drivers/protocols, one target per protocol so each mutant runs only its own tests ("protocols": all)
    "protocols-mit": (["drivers/protocols/mit.py", "drivers/protocols/mit_layout.py"],
                      "tests/can/test_mit_layout.py tests/can/test_mit_codec.py tests/can/test_mit_drive.py "
                      "tests/can/test_mit_can_driver.py", 240),
    "protocols-cia402": (["drivers/protocols/cia402.py", "drivers/protocols/cia402_layout.py"],
                         "tests/can/test_cia402_layout.py tests/can/test_cia402_protocol.py "
                         "tests/can/test_cia402_driver.py", 240),
    "protocols-leg": (["drivers/protocols/leg_board.py"], "tests/leg/test_codec.py tests/leg/test_serial_board.py", 180),
    "can_joints": (["drivers/can_joints.py"], "tests/can/test_mit_can_driver.py tests/can/test_mit_can_config.py "
                   "tests/can/test_can_joints_survivors.py tests/hil/test_can_config.py", 240),
    "urdf": (["rtctl/model/urdf.py"], "tests/model/test_urdf.py tests/model/test_urdf_survivors.py", 180),
    "control": (["rtctl/control"], "tests/control tests/leg/test_controller.py tests/leg/test_leg_actions.py", 600),  # (the leg automaton's)
    # issue 27 part 3: the newer modules (the guard's and the CiA 402 driver's are safety-relevant)
    "guard": (["rtctl/guard/kernels.py", "rtctl/guard/feasibility.py", "rtctl/guard/zones.py",
               "rtctl/guard/runtime.py", "rtctl/guard/grid.py", "rtctl/guard/visibility.py",
               "rtctl/guard/planner.py", "rtctl/guard/motion.py"],
              "tests/guard", 400),  # (with the closed loop on the embedded PUMA 560: 23 of its ~50 s)
    "cia402_driver": (["drivers/cia402_frames.py", "drivers/cia402_joints.py"],
                      "tests/can/test_cia402_driver.py tests/can/test_cia402_consumer.py "
                      "tests/can/test_cia402_protocol.py tests/can/test_cia402_config.py "
                      "tests/can/test_cia402_lifecycle.py tests/can/test_cia402_frames.py "
                      "tests/can/test_cia402_disable_budget.py "
                      "tests/can/test_busload.py", 300),  # (test_busload: its bus budget)
    "estimation": (["rtctl/estimation"], "tests/estimation", 300),
    "logic": (["rtctl/logic"], "tests/leg/test_synthesis.py tests/leg/test_circuit_by_brute_force.py "
              "tests/leg/test_table.py tests/leg/test_compile_limits.py tests/leg/test_walking.py "
              "tests/leg/test_logic_survivors.py tests/leg/test_logic_survivors_part2.py tests/leg/test_logic_survivors_part3.py "
              "tests/leg/test_logic_survivors_part4.py tests/leg/test_logic_survivors_part5.py "
              "tests/leg/test_logic_survivors_part6.py tests/leg/test_logic_survivors_part7.py "
              "tests/leg/test_minimiser.py tests/leg/test_guard_lag.py tests/leg/test_controller.py "
              "tests/leg/test_logic_report_limits.py tests/leg/test_logic_survivors_part8.py "
              "tests/leg/test_logic_survivors_part9.py tests/leg/test_logic_survivors_part10.py "
              "tests/leg/test_logic_survivors_part11.py", 300),
    "vision": (["rtctl/vision", "drivers/protocols/framegrabber.py", "drivers/protocols/framegrabber_host.py"],
               "tests/vision tests/hil/test_framegrabber_hil.py tests/control/test_constructor_defaults.py", 300),  # (with the daemon runs: 19 s; the HIL runs: 35 s)
    "mcap": (["rtctl/telemetry/mcap_export.py", "rtctl/telemetry/channels.py"],  # (channels: shared with the live view)
             "tests/telemetry/test_mcap_export.py tests/telemetry/test_mcap_times_and_levels.py "
             "tests/telemetry/test_mcap_events_and_stamps.py tests/telemetry/test_mcap_channels.py "
             "tests/telemetry/test_foxglove_layout.py "
             "tests/telemetry/test_live_view.py", 240),
    "trajectory": (["rtctl/trajectory"], "tests/trajectory tests/moves/test_move_units.py tests/moves/test_move_targets.py",
                   240),
}
