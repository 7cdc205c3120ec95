#!/usr/bin/env python3
"""The outage study's table (docs/studies/faults.md, "Outages while a holder stands inside"): for
each preset, stalled holder and outage kind, how many runs had a collision, a mutex violation, a
gridlock, a lease expiry, and passed. Reads a sweep folder of scenarios/studies/outages.yaml
(results.csv for each run's point, the run's summary.json for its verdicts) and prints Markdown.

    python3 tools/outage_table.py runs/study_outages
"""
import collections
import csv
import json
import os
import sys

COLUMNS = ['runs', 'collision', 'mutex violation', 'gridlock', 'lease expired', 'passed']


def failed(summary, prefix):
    return any(e['name'].startswith(prefix) and not e['passed'] for e in summary['expectations'])


def main(folder):
    counts = collections.defaultdict(collections.Counter)
    with open(os.path.join(folder, 'results.csv')) as f:
        for row in csv.DictReader(f):
            with open(os.path.join(folder, 'runs', row['run_id'], 'summary.json')) as s:
                summary = json.load(s)
            kind = row['faults[1]'].split('_')[0]
            key = (row['stack.preset'], row['faults[0]'], kind)
            c = counts[key]
            c['runs'] += 1
            c['collision'] += failed(summary, 'no_collision')
            c['mutex violation'] += failed(summary, 'intersection_mutex')
            c['gridlock'] += failed(summary, 'no_gridlock')
            c['lease expired'] += summary['server'].get('lease_expiries', 0) > 0
            c['passed'] += summary['passed']
    print('| preset | holder | outage | ' + ' | '.join(COLUMNS) + ' |')
    print('|---|---|---|' + '---|' * len(COLUMNS))
    for key in sorted(counts):
        print('| `{}` | {} | {} | '.format(*key) +
              ' | '.join(str(counts[key][c]) for c in COLUMNS) + ' |')


if __name__ == '__main__':
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
