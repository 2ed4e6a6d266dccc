"""The fixed-step loop: its design, the compiled tick and pacing, the thread driver, the supervisor and faults, replay, the timing budget."""
