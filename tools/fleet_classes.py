#!/usr/bin/env python3
"""The fleet study's table (docs/studies/fleet.md): for each stack preset and number of cars,
in how many runs each failure class happened. Reads a sweep folder's runs (summary.json,
scenario.resolved.json, events.jsonl) and prints a Markdown table.

    python3 tools/fleet_classes.py runs/study_fleet

A car "waits for ever" when its last wait at a stop box began at least 30 s before the end and
never ended in a `go`; the cause is "lost message" when its request or the answer to it was lost
(`v2i_lost`), else "denied, never re-asks" when the server's last answer to it was a denial.
"""
import collections
import glob
import json
import os
import sys

WAIT_BEFORE_END_S = 30.0
CLASSES = ['passed', 'collision', 'entry without grant', 'mutex violation',
           'waits for ever: lost message', 'waits for ever: denied, never re-asks',
           'navigation failed']


def load_jsonl(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def classes_of(summary, events):
    found = set()
    if summary['passed']:
        found.add('passed')
    for car in summary['cars']:
        mine = [e for e in events if e.get('car') == car['id']]
        waits = [i for i, e in enumerate(mine) if e['type'] == 'wait']
        if waits and mine[waits[-1]]['t_s'] <= summary['sim_seconds'] - WAIT_BEFORE_END_S:
            first = waits[-1]
            while first > 0 and mine[first - 1]['t_s'] == mine[first]['t_s']:
                first -= 1  # a request lost at the instant of the wait is logged before it
            since = mine[first:]
            if not any(e['type'] == 'go' for e in since):
                lost = [e for e in since if e['type'] == 'v2i_lost' and
                        (e['detail'].startswith('/vtl/request') or
                         e['detail'].split("'")[1][:-1] == str(car['id']))]
                answers = [e for e in since if e['type'] in ('grant', 'denied')]
                if lost:
                    found.add('waits for ever: lost message')
                elif answers and answers[-1]['type'] == 'denied':
                    found.add('waits for ever: denied, never re-asks')
        if car.get('stack', {}).get('navigation_failed'):
            found.add('navigation failed')
    if any(e['type'] == 'collision' for e in events):
        found.add('collision')
    if any(e['type'] == 'enter' and not e.get('granted') for e in events):
        found.add('entry without grant')
    if any(not x['passed'] and x['name'].startswith('intersection_mutex')
           for x in summary['expectations']):
        found.add('mutex violation')
    return found


def main(sweep_dir):
    groups = collections.defaultdict(collections.Counter)
    for path in glob.glob(os.path.join(sweep_dir, 'runs', '*', 'summary.json')):
        run = os.path.dirname(path)
        with open(path) as f:
            summary = json.load(f)
        with open(os.path.join(run, 'scenario.resolved.json')) as f:
            scenario = json.load(f)['scenario']
        preset = (scenario.get('stack') or {}).get('preset') or 'none'
        group = groups[(preset, len(scenario['cars']))]
        group['runs'] += 1
        for c in classes_of(summary, load_jsonl(os.path.join(run, 'events.jsonl'))):
            group[c] += 1
    print('| preset | cars | runs | ' + ' | '.join(CLASSES) + ' |')
    print('|---|---|---|' + '---|' * len(CLASSES))
    for (preset, cars), g in sorted(groups.items(), key=lambda kv: (kv[0][0] != 'lab', kv[0][1])):
        print(f'| `{preset}` | {cars} | {g["runs"]} | ' + ' | '.join(str(g[c]) for c in CLASSES) + ' |')


if __name__ == '__main__':
    if len(sys.argv) != 2:
        sys.exit('usage: fleet_classes.py SWEEP_DIR (the folder `autonomsim sweep --out` wrote)')
    main(sys.argv[1])
