#!/usr/bin/env bash
# A one-node Slurm cluster on this machine (munged, slurmctld, slurmd; no systemd), all its state
# in DIR: for trying tools/slurm_parts.sh, and for its test (tests/split.rs). Needs root and
# Debian's slurm-wlm and munge (22.05); nothing in /etc is touched.
#
#   tools/slurm_one_node.sh start DIR    # then: export SLURM_CONF=DIR/slurm.conf
#   tools/slurm_one_node.sh stop DIR     # cancels its jobs and stops the daemons
#
# SLURM_PORTS="CTLD SLURMD" picks the ports (default 6817 6818). Credentials expire after 5 s
# (Slurm's least), so a requeued job is eligible again 6 s later rather than 121 s.
set -euo pipefail

die() { echo "slurm_one_node.sh: $*" >&2; exit 1; }

start() {
    local dir node cpus i state=""
    mkdir -p "$1"
    dir=$(cd "$1" && pwd)
    node=$(hostname -s)
    cpus=$(nproc)
    read -r ctld_port slurmd_port <<< "${SLURM_PORTS:-6817 6818}"
    mkdir -p "$dir"/{munge,ctld,slurmd,run,log}
    # munged wants every folder on its socket's path searchable by all, and a private key.
    chmod 755 "$dir" "$dir/munge"
    [ -f "$dir/munge/munge.key" ] || mungekey -c -k "$dir/munge/munge.key" -b 1024
    chmod 600 "$dir/munge/munge.key"
    : > "$dir/plugstack.conf"
    cat > "$dir/slurm.conf" <<EOF
ClusterName=dualhair-test
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket,cred_expire=5
CredType=cred/munge
StateSaveLocation=$dir/ctld
SlurmdSpoolDir=$dir/slurmd
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
PlugStackConfig=$dir/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
JobRequeue=1
MinJobAge=300
KillWait=5
EnforcePartLimits=ALL
SchedulerParameters=sched_interval=1
NodeName=$node NodeHostname=$node NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=debug Nodes=$node Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
EOF
    export SLURM_CONF=$dir/slurm.conf
    setsid munged -F --key-file="$dir/munge/munge.key" -S "$dir/munge/munge.socket" \
        --pid-file="$dir/run/munged.pid" --seed-file="$dir/munge/munged.seed" \
        --log-file="$dir/log/munged.log" < /dev/null > "$dir/log/munged.out" 2>&1 &
    echo $! > "$dir/run/munged.fg"
    for i in $(seq 50); do [ -S "$dir/munge/munge.socket" ] && break; sleep 0.1; done
    munge -S "$dir/munge/munge.socket" -n | unmunge -S "$dir/munge/munge.socket" > /dev/null \
        || die "munged does not work: $dir/log/munged.out"
    setsid slurmctld -D -i -f "$dir/slurm.conf" < /dev/null > "$dir/log/slurmctld.out" 2>&1 &
    echo $! > "$dir/run/slurmctld.fg"
    for i in $(seq 100); do scontrol ping 2> /dev/null | grep -q UP && break; sleep 0.2; done
    scontrol ping | grep -q UP || die "slurmctld is not up: $dir/log/slurmctld.log"
    setsid slurmd -D -N "$node" -f "$dir/slurm.conf" < /dev/null > "$dir/log/slurmd.out" 2>&1 &
    echo $! > "$dir/run/slurmd.fg"
    for i in $(seq 150); do
        state=$(sinfo -h -N -n "$node" -o %T 2> /dev/null || true)
        [ "$state" = idle ] && break
        sleep 0.2
    done
    [ "$state" = idle ] || die "the node is '$state', not idle: $dir/log/slurmd.log"
}

stop() {
    local dir p pid i pids="" kids
    dir=$(cd "$1" && pwd)
    export SLURM_CONF=$dir/slurm.conf
    # `scontrol shutdown` leaves running jobs running: cancel them first.
    if scontrol ping 2> /dev/null | grep -q UP; then
        scancel --partition=debug > /dev/null 2>&1 || true
        for i in $(seq 150); do [ -z "$(squeue -h -o %i 2> /dev/null)" ] && break; sleep 0.1; done
    fi
    scontrol shutdown > /dev/null 2>&1 || true
    for p in slurmd slurmctld munged; do
        [ -f "$dir/run/$p.fg" ] || continue
        pid=$(cat "$dir/run/$p.fg")
        [ "$p" = munged ] && kill -TERM "$pid" 2> /dev/null || true
        for i in $(seq 100); do kill -0 "$pid" 2> /dev/null || break; sleep 0.1; done
        kill -KILL "$pid" 2> /dev/null || true
        rm -f "$dir/run/$p.fg"
    done
    # Job steps this cluster started (they carry its SLURM_CONF), and their children.
    for p in $(pgrep -x slurmstepd || true); do
        tr '\0' '\n' < "/proc/$p/environ" 2> /dev/null | grep -qx "SLURM_CONF=$dir/slurm.conf" && pids="$pids $p"
    done
    kids=$pids
    while [ -n "$kids" ]; do
        kids=$(for p in $kids; do pgrep -P "$p" || true; done)
        pids="$pids $kids"
    done
    [ -z "${pids// /}" ] || kill -KILL $pids 2> /dev/null || true
}

case "${1:-}" in
start) start "${2:?usage: $0 start DIR}" ;;
stop) stop "${2:?usage: $0 stop DIR}" ;;
*) echo "usage: $0 start|stop DIR" >&2; exit 2 ;;
esac
