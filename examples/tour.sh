#!/usr/bin/env bash
# The README's tour: every command in order, each on files an earlier one made.
# Run it from an empty directory (CI does):
#
#     mkdir tour && cd tour && bash /path/to/eddi-station/examples/tour.sh
#
# It needs only the package (`pip install -e ".[report]"`); no hardware. STATION overrides the
# command (default: `station`), e.g. STATION="python -m station.cli".
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(dirname "$here")
station=${STATION:-station}
step() { printf '\n$ station %s\n' "$*"; $station "$@"; }

step --version
step devices                                                   # serial ports, USB DAQs, simulated systems

# 1. the whole chain on the simulated rig: session.h5, model.json, report/ in demo-out/
step demo --out demo-out --seed 1

# 2. record three impacts from the rig (the bench configuration sets rate, trigger, mass...)
step acquire --device sim://duffing-smooth --impacts 3 --out session.h5 --config "$here/bench.toml"

# 3. identify on one capture, validate the demo's model on the others (captures are 0-based)
step identify session.h5:1 --damping v,x^2*v,v^3 --stiffness x,x^3 --json > identify.json
step validate demo-out/model.json session.h5:0 session.h5:2

# 4. what the model gets wrong and why; the extended model is validated in turn
step diagnose session.h5:0 session.h5:1 session.h5:2 --save-model extended.json --report diag
step validate extended.json session.h5:0

# 5. report, replay (also through the emulated device), exchange formats
step report session.h5 --out report
step replay session.h5 --through-device
step export session.h5 --uff session.uff
step export session.h5 --sep005 session-sep005.json
step import "$repo/station/examples/duffing-impact.csv" --out imported.h5 --mass 0.815
step identify imported.h5:0

# 6. the rig as a device of its own, struck from another process (no terminal needed)
$station rig serve --system duffing-smooth --unpaced --link rig.port --control rig.ctl --json > serve.json &
serve=$!
trap 'kill $serve 2>/dev/null || true' EXIT
for _ in $(seq 1 600); do [ -S rig.ctl ] && break; sleep 0.1; done
$station acquire --device "serial://$PWD/rig.port" --impacts 1 --out served.h5 --config "$here/bench.toml" \
    --idle-timeout 60 --json > served.json &
acq=$!
printf '\n$ station rig strike --control rig.ctl --force-n 600   (until the capture is saved)\n'
# one blow, then up to 20 s for the capture before another (a blow while the capture records
# would be a second blow in it: a busy machine runs the unpaced rig slower than 16 s a second)
for _ in $(seq 1 10); do
    kill -0 $acq 2>/dev/null || break
    # a rig compiling its simulation on an empty JIT cache may answer after the strike's 10 s
    # (the blow is still delivered): wait for the capture either way, strike again only then
    $station rig strike --control rig.ctl --force-n 600 >/dev/null || true
    for _ in $(seq 1 40); do kill -0 $acq 2>/dev/null || break; sleep 0.5; done
done
wait $acq
cat served.json
step identify served.h5:0 --mass 0.815
printf '\ntour done: every command ran on files an earlier one made\n'
