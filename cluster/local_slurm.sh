#!/usr/bin/env bash
# A single-node SLURM cluster on this machine: the scheduler the cluster path (hydra/launcher=cluster) is tested on.
#
#   cluster/local_slurm.sh up       install (Debian's packages) and start it; does nothing when it runs already
#   cluster/local_slurm.sh install  install Debian's packages only (what up does first, when they are missing)
#   cluster/local_slurm.sh down     cancel its jobs and stop the daemons it started (by their PID files)
#   cluster/local_slurm.sh status   its daemons, its node and partition, the commands' configuration
#
# What runs: munged (authentication), MariaDB and slurmdbd (the accounting that sacct and submitit read),
# slurmctld (the controller) and slurmd (the one node, with this machine's cores and most of its memory), in one
# partition `local`. Everything it writes lives under one state directory ($TASKCOMPLEXITY_CLUSTER, by default
# outputs/cluster of this checkout): the configuration, the munge key, the database, the spool and the logs
# (log/*.log). The system's /etc/slurm/slurm.conf is made a link to the configuration only where no file is
# there, so that sbatch, squeue and sacct find it without SLURM_CONF; `down` removes that link again.
#
# The settings are those a 2-core VM with cgroups in hybrid mode and no systemd accepts: process tracking by
# /proc (proctrack/linuxproc), no task plugin, cores and memory as consumable resources, cgroup/v1.
set -euo pipefail

ROOT="$(cd "$(dirname "$0")/.." && pwd)"
STATE="${TASKCOMPLEXITY_CLUSTER:-$ROOT/outputs/cluster}"
CONF="$STATE/etc/slurm.conf"
PARTITION=local
CLUSTER=taskcomplexity
DB_PORT="${TASKCOMPLEXITY_CLUSTER_DB_PORT:-6833}"
SYSTEM_CONF=/etc/slurm/slurm.conf
MARK="# The local single-node cluster of cluster/local_slurm.sh"   # the first line of its slurm.conf
PACKAGES=(munge mariadb-server slurmdbd slurmctld slurmd slurm-client)
DAEMONS=(slurmd slurmctld slurmdbd mariadbd munged)
# The order they stop in, a group at a time (each group's daemons at once): the controller and the node while the
# accounting still runs, the accounting while its database and munge still run, then those two.
STOP_GROUPS=("slurmd slurmctld" "slurmdbd" "mariadbd munged")
# The accounting database holds a few hundred rows: InnoDB's defaults (a 96 MB redo log, a 128 MB buffer pool) would
# take disk and memory a CI machine may not have.
INNODB=(--innodb-buffer-pool-size=64M --innodb-log-file-size=8M)
export SLURM_CONF="$CONF"

say() { echo "local cluster: $*"; }
fail() { echo "error: local cluster: $*" >&2; exit 1; }

pid_of() {  # the PID of a daemon this script started, if it is alive
    local file="$STATE/run/$1.pid"
    [[ -s "$file" ]] || return 1
    local pid
    pid="$(tr -dc 0-9 < "$file")"
    [[ -n "$pid" ]] && kill -0 "$pid" 2>/dev/null && echo "$pid"
}

wait_for() {  # wait_for SECONDS WHAT COMMAND...: poll COMMAND until it succeeds
    local seconds="$1" what="$2"
    shift 2
    for _ in $(seq $((seconds * 4))); do
        "$@" >/dev/null 2>&1 && return 0
        sleep 0.25
    done
    fail "$what did not come up in ${seconds}s (logs: $STATE/log/)"
}

install_packages() {
    local missing=()
    for binary in munged mariadbd slurmdbd slurmctld slurmd sbatch; do
        command -v "$binary" >/dev/null 2>&1 || missing+=("$binary")
    done
    [[ ${#missing[@]} -eq 0 ]] && return 0
    [[ $EUID -eq 0 ]] || fail "${missing[*]} not installed and not root: install ${PACKAGES[*]} (Debian), or run as root"
    command -v apt-get >/dev/null 2>&1 || fail "${missing[*]} not installed and no apt-get: install SLURM 22.05+, munge and MariaDB"
    say "installing ${PACKAGES[*]} (apt-get)"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null
    apt-get install -y -qq --no-install-recommends -o APT::Keep-Downloaded-Packages=false "${PACKAGES[@]}" >/dev/null
}

write_config() {
    local host cpus memory
    host="$(hostname -s)"
    cpus="$(nproc)"
    # The node offers 90 % of the machine's memory (slurmd refuses a node that claims more than it has).
    memory="$(awk '/MemTotal/ {printf "%d", $2 / 1024 * 0.9}' /proc/meminfo)"
    mkdir -p "$STATE"/{etc,run,log,munge,spool/ctld,spool/d,mysql}
    chmod 755 "$STATE/munge"   # munged wants its socket reachable by every user
    cat > "$CONF" <<EOF
$MARK (written by \`up\`; edits are lost at the next start).
ClusterName=$CLUSTER
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
# cred_expire: also how long a requeued job waits before it may start again (default 120 s; a local node needs less).
AuthInfo=socket=$STATE/munge/munge.socket.2,cred_expire=15
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
ReturnToService=2
StateSaveLocation=$STATE/spool/ctld
SlurmdSpoolDir=$STATE/spool/d
SlurmctldPidFile=$STATE/run/slurmctld.pid
SlurmdPidFile=$STATE/run/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=localhost
# The munge socket of connections to slurmdbd (AuthInfo covers the others).
AccountingStoragePass=$STATE/munge/munge.socket.2
JobAcctGatherType=jobacct_gather/linux
JobAcctGatherFrequency=task=5
JobCompType=jobcomp/filetxt
JobCompLoc=$STATE/log/jobcomp.log
# Fast turnaround for short test jobs: a cancelled or timed-out job is signalled, then killed 5 s later.
KillWait=5
MinJobAge=60
SchedulerParameters=sched_interval=2
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=$PARTITION Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
    cat > "$STATE/etc/cgroup.conf" <<EOF
CgroupPlugin=cgroup/v1
IgnoreSystemd=yes
EOF
    (umask 077; cat > "$STATE/etc/slurmdbd.conf" <<EOF
AuthType=auth/munge
AuthInfo=socket=$STATE/munge/munge.socket.2
DbdHost=localhost
SlurmUser=root
PidFile=$STATE/run/slurmdbd.pid
LogFile=$STATE/log/slurmdbd.log
StorageType=accounting_storage/mysql
StorageHost=127.0.0.1
StoragePort=$DB_PORT
StorageUser=slurm
StoragePass=local-cluster
StorageLoc=slurm_acct_db
EOF
    )
    [[ -s "$STATE/munge/munge.key" ]] || (umask 077; head -c 1024 /dev/urandom > "$STATE/munge/munge.key")
}

start_munge() {
    pid_of munged >/dev/null && return 0
    munged --force --key-file="$STATE/munge/munge.key" --socket="$STATE/munge/munge.socket.2" \
        --pid-file="$STATE/run/munged.pid" --log-file="$STATE/log/munged.log" --seed-file="$STATE/munge/munged.seed"
    wait_for 10 munged test -S "$STATE/munge/munge.socket.2"
}

sql() { mariadb --protocol=socket --socket="$STATE/run/mysqld.sock" -u root "$@"; }

start_database() {
    pid_of mariadbd >/dev/null && return 0
    if [[ ! -d "$STATE/mysql/mysql" ]]; then
        mariadb-install-db --user=root --datadir="$STATE/mysql" --auth-root-authentication-method=socket \
            --skip-test-db "${INNODB[@]}" > "$STATE/log/mariadb-install.log" 2>&1 || fail "mariadb-install-db failed (log: $STATE/log/mariadb-install.log)"
    fi
    setsid mariadbd --user=root --datadir="$STATE/mysql" --socket="$STATE/run/mysqld.sock" --port="$DB_PORT" \
        --bind-address=127.0.0.1 --pid-file="$STATE/run/mariadbd.pid" --log-error="$STATE/log/mariadb.log" \
        "${INNODB[@]}" < /dev/null > /dev/null 2>&1 &
    wait_for 60 MariaDB sql -e "select 1"
    sql -e "CREATE DATABASE IF NOT EXISTS slurm_acct_db;
            CREATE USER IF NOT EXISTS 'slurm'@'127.0.0.1' IDENTIFIED BY 'local-cluster';
            GRANT ALL ON slurm_acct_db.* TO 'slurm'@'127.0.0.1';"
}

start_slurm() {
    if ! pid_of slurmdbd >/dev/null; then
        slurmdbd
        wait_for 60 slurmdbd timeout 5 sacctmgr -n list cluster
    fi
    sacctmgr -n list cluster format=cluster | grep -qw "$CLUSTER" || sacctmgr -i add cluster "$CLUSTER" >/dev/null
    # -c: a controller and a node that start clean (no jobs of an earlier start of this directory).
    pid_of slurmctld >/dev/null || slurmctld -c
    wait_for 30 slurmctld scontrol ping
    pid_of slurmd >/dev/null || slurmd -c
    wait_for 60 "the node" bash -c "sinfo -h -p $PARTITION -o %T | grep -qE '^(idle|mixed|allocated|completing)'"
}

link_system_config() {
    # A link this script left (to another checkout's cluster, or dangling after a machine restart) is replaced; a
    # system's own slurm.conf, a file, never is.
    if [[ -L "$SYSTEM_CONF" ]] && { [[ ! -e "$SYSTEM_CONF" ]] || head -1 "$SYSTEM_CONF" | grep -qF "$MARK"; }; then
        rm -f "$SYSTEM_CONF"
    fi
    if [[ ! -e "$SYSTEM_CONF" && ! -L "$SYSTEM_CONF" ]]; then
        mkdir -p "$(dirname "$SYSTEM_CONF")"
        ln -s "$CONF" "$SYSTEM_CONF"
    fi
}

running() {  # every daemon alive and the node answering
    for daemon in "${DAEMONS[@]}"; do pid_of "$daemon" >/dev/null || return 1; done
    sinfo -h -p "$PARTITION" -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated|completing)'
}

up() {
    if [[ -f "$CONF" ]] && running; then
        say "running already ($STATE)"
        return 0
    fi
    [[ $EUID -eq 0 ]] || fail "not root: slurmd starts jobs as their users, which needs root (run as root, or use a real cluster)"
    install_packages
    local started=$SECONDS
    # A start after a stop (or a machine restart) begins from an empty directory: job ids restart at 1, and an
    # old database would hold other jobs under the same ids.
    if [[ -d "$STATE" ]] && ! pid_of mariadbd >/dev/null && ! pid_of slurmctld >/dev/null; then
        rm -rf "$STATE"
    fi
    write_config
    start_munge
    start_database
    start_slurm
    link_system_config
    say "up in $((SECONDS - started))s: partition '$PARTITION' on node $(hostname -s) ($(nproc) CPUs); state and logs in $STATE"
    [[ "$(readlink "$SYSTEM_CONF" 2>/dev/null)" == "$CONF" ]] || say "set SLURM_CONF=$CONF for sbatch, squeue and sacct"
}

down() {
    local stopped=()
    if pid_of slurmctld >/dev/null; then   # the jobs first: their steps are no daemon of ours but would outlive us
        scancel --full --quiet --partition="$PARTITION" 2>/dev/null || true
        for _ in $(seq 60); do
            [[ -z "$(squeue -h -p "$PARTITION" -o %i 2>/dev/null)" ]] && break
            sleep 0.5
        done
    fi
    local group daemon pid
    for group in "${STOP_GROUPS[@]}"; do   # TERM a group's daemons, then wait for each (KILL after 30 s)
        local pids=()
        for daemon in $group; do
            pid="$(pid_of "$daemon")" || continue
            kill -TERM "$pid"
            pids+=("$pid")
            stopped+=("$daemon($pid)")
        done
        for pid in ${pids[@]+"${pids[@]}"}; do
            for _ in $(seq 60); do kill -0 "$pid" 2>/dev/null || break; sleep 0.5; done
            if kill -0 "$pid" 2>/dev/null; then kill -KILL "$pid"; fi
        done
    done
    pkill -KILL -f "^slurmstepd: \[" 2>/dev/null || true   # a job step left without its slurmd
    if [[ "$(readlink "$SYSTEM_CONF" 2>/dev/null)" == "$CONF" ]]; then rm -f "$SYSTEM_CONF"; fi
    if [[ ${#stopped[@]} -gt 0 ]]; then say "stopped ${stopped[*]}; logs kept in $STATE/log until the next up"; else say "not running"; fi
}

status() {
    for daemon in "${DAEMONS[@]}"; do
        if pid="$(pid_of "$daemon")"; then echo "$daemon: running (pid $pid)"; else echo "$daemon: stopped"; fi
    done
    if pid_of slurmctld >/dev/null; then
        sinfo -p "$PARTITION"
        echo "SLURM_CONF=$CONF"
    fi
    running
}

case "${1:-}" in
    up) up ;;
    install) install_packages ;;
    down) down ;;
    status) status ;;
    *) echo "usage: $0 up|install|down|status" >&2; exit 2 ;;
esac
