# The bundled replays whose outputs tests/data/replay_hashes.txt pins, by name: the scenario, the
# log (empty: the scenario's own) and what the log is there to show. Paths are relative to the
# source tree, where the replays run, so that report.json names the same inputs on every machine.
set(scalpel_replays default tremble crossing)
set(scalpel_replay_default_scenario config/scenarios/skin_incision.yaml)
set(scalpel_replay_default_log "")
# Tremor, two pull-backs and re-cuts: the blunt side leads at least once.
set(scalpel_replay_tremble_scenario config/scenarios/skin_incision.yaml)
set(scalpel_replay_tremble_log config/logs/skin_incision_tremble.csv)
set(scalpel_replay_tremble_min_backward 1)
# A second incision across the first, which continues it recursively.
set(scalpel_replay_crossing_scenario config/scenarios/skin_incision_cross.yaml)
set(scalpel_replay_crossing_log "")
set(scalpel_replay_crossing_min_recursions 1)
