"""The control socket's ``move``, planned away from the loop (docs/architecture.md, "Moves").

* :mod:`~rtctl.moves.plan` — what a move is: waypoints and times → a trajectory from a given
  reference state, or the reason it is refused (pure; runs in the planner process);
* :mod:`~rtctl.moves.worker` — the planner process: requests in on a pipe, trajectories out;
* :mod:`~rtctl.moves.pending` — the loop's side: hands a request to the planner, answers
  ``busy`` while one is pending, and swaps the finished trajectory in at a tick boundary.
"""
