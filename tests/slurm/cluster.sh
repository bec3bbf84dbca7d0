#!/usr/bin/env bash
# A throw-away single-node SLURM cluster with job accounting, on loopback, for tests/test_slurm.py.
#
#   tests/slurm/cluster.sh start DIR   # install what is missing, start the daemons, print the env
#   tests/slurm/cluster.sh stop DIR    # cancel the jobs, stop exactly the daemons 'start' started
#
# 'start' needs root and Debian's apt when a package is missing (slurm-wlm, slurmdbd, munge,
# mariadb-server); it never starts a package's system service (no systemd needed). Everything else
# lives in DIR: configuration, munge key, MariaDB data, spool and state, logs, and one pid file per
# daemon (DIR/pids/*.pid, written from the PID of the process this script started). The daemons
# (munged, mariadbd, slurmdbd, slurmctld, slurmd) listen on 127.0.0.1 only, on free ports picked at
# start. Clients use the cluster through SLURM_CONF=DIR/etc/slurm.conf and PATH=DIR/bin:$PATH
# (both written to DIR/env; see the srun note at the end of 'start').
# If 'start' fails, it stops what it started and exits non-zero with the reason and the log tails.
set -euo pipefail

CLUSTER=tyreroad
ACCOUNT=tyreroad-test        # the account jobs must name (accounting enforces associations)
PARTITION=debug              # the only partition, and the default one
PACKAGES=(slurm-wlm slurmdbd munge mariadb-server)
DAEMONS=(munged mariadbd slurmdbd slurmctld slurmd)   # start order; stopped in reverse

die() { echo "cluster.sh: $*" >&2; exit 1; }

usage() { die "usage: $0 start DIR | stop DIR"; }

have_all() {
    local cmd
    for cmd in munged mariadbd mariadb-install-db slurmdbd slurmctld slurmd sbatch sacct sacctmgr; do
        command -v "$cmd" >/dev/null 2>&1 || PATH="$PATH:/usr/sbin:/sbin" command -v "$cmd" >/dev/null 2>&1 || return 1
    done
}

install_packages() {
    have_all && return 0
    [ "$(id -u)" = 0 ] || die "SLURM is not installed and installing it needs root: apt-get install ${PACKAGES[*]}"
    command -v apt-get >/dev/null || die "SLURM is not installed and there is no apt-get to install ${PACKAGES[*]}"
    # keep the packages' maintainer scripts from starting system services
    local policy=/usr/sbin/policy-rc.d made_policy=0
    if [ ! -e "$policy" ]; then
        printf '#!/bin/sh\nexit 101\n' > "$policy" && chmod 755 "$policy" && made_policy=1
    fi
    local rc=0
    {
        apt-get update -q &&
        DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${PACKAGES[@]}"
    } >&2 || rc=$?
    [ "$made_policy" = 1 ] && rm -f "$policy"
    [ "$rc" = 0 ] || die "apt-get install ${PACKAGES[*]} failed (exit $rc)"
    have_all || die "installed ${PACKAGES[*]} but a daemon or client is still missing"
}

free_ports() {  # N free TCP ports on 127.0.0.1
    "$(command -v python3 || command -v python)" - "$1" <<'EOF'
import socket, sys
socks = [socket.socket() for _ in range(int(sys.argv[1]))]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(" ".join(str(s.getsockname()[1]) for s in socks))
EOF
}

launch() {  # launch NAME CMD...: start a daemon in the foreground mode, in the background
    local name=$1; shift
    "$@" >> "$DIR/log/$name.out" 2>&1 < /dev/null &
    echo $! > "$DIR/pids/$name.pid"
}

alive() { [ -f "$DIR/pids/$1.pid" ] && kill -0 "$(cat "$DIR/pids/$1.pid")" 2>/dev/null; }

wait_for() {  # wait_for SECONDS WHAT CMD...: poll CMD until it succeeds
    local limit=$1 what=$2; shift 2
    local t0=$SECONDS out
    until out=$("$@" 2>&1); do
        (( SECONDS - t0 < limit )) || die "$what not ready after ${limit} s: $* said: $out"
        sleep 0.2
    done
}

log_tails() {
    local f
    for f in "$DIR"/log/*; do
        [ -s "$f" ] || continue
        echo "----- $f (last 15 lines)" >&2
        tail -n 15 "$f" >&2
    done
}

stop_daemons() {
    local i name pid t0
    if alive slurmctld && [ -f "$DIR/etc/slurm.conf" ]; then
        # cancel every job first, so that no job step outlives slurmd
        SLURM_CONF="$DIR/etc/slurm.conf" scancel --cluster="$CLUSTER" --user="$(id -un)" 2>/dev/null || true
        t0=$SECONDS
        while (( SECONDS - t0 < 30 )) && [ -n "$(SLURM_CONF="$DIR/etc/slurm.conf" squeue -h -o %i 2>/dev/null)" ]; do
            sleep 0.5
        done
    fi
    for (( i = ${#DAEMONS[@]} - 1; i >= 0; i-- )); do
        name=${DAEMONS[$i]}
        [ -f "$DIR/pids/$name.pid" ] || continue
        pid=$(cat "$DIR/pids/$name.pid")
        # the PID is ours only while it still runs the program we started
        if kill -0 "$pid" 2>/dev/null && grep -qa "$name" "/proc/$pid/cmdline" 2>/dev/null; then
            kill -TERM "$pid" 2>/dev/null || true
            t0=$SECONDS
            while kill -0 "$pid" 2>/dev/null && (( SECONDS - t0 < 20 )); do sleep 0.2; done
            if kill -0 "$pid" 2>/dev/null; then
                echo "cluster.sh: $name (pid $pid) ignored SIGTERM, killing it" >&2
                kill -KILL "$pid" 2>/dev/null || true
            fi
        fi
        rm -f "$DIR/pids/$name.pid"
    done
}

start() {
    local t_start=$SECONDS
    install_packages
    export PATH="$PATH:/usr/sbin:/sbin"
    [ ! -e "$DIR/pids" ] || [ -z "$(ls -A "$DIR/pids")" ] || die "$DIR/pids is not empty: is a cluster running there? ($0 stop $DIR)"
    mkdir -p "$DIR"/{etc,pids,log,munge,mysql,state,spool,jobs}
    chmod 700 "$DIR/munge" "$DIR/etc"
    trap 'rc=$?; if [ $rc != 0 ]; then log_tails; stop_daemons; fi' EXIT

    local host user ports ctld_port slurmd_port dbd_port db_port cpus mem_mb db_pass
    host=$(uname -n); host=${host%%.*}
    user=$(id -un)
    read -r ctld_port slurmd_port dbd_port db_port <<< "$(free_ports 4)"
    cpus=$(nproc)
    mem_mb=$(awk '/MemTotal/ {printf "%d", $2 / 1024 * 0.9}' /proc/meminfo)
    db_pass=$(od -An -N12 -tx1 /dev/urandom | tr -d ' \n')

    # --- munge: a fresh key, its own socket
    dd if=/dev/urandom of="$DIR/munge/munge.key" bs=1024 count=1 status=none
    chmod 400 "$DIR/munge/munge.key"
    local munge_socket="$DIR/munge/munge.socket.2"
    launch munged munged --foreground --force --key-file="$DIR/munge/munge.key" \
        --socket="$munge_socket" --pid-file="$DIR/munge/munged.pid" \
        --seed-file="$DIR/munge/munged.seed" --log-file="$DIR/log/munged.log"
    wait_for 10 munged munge --socket="$munge_socket" -n

    # --- MariaDB on loopback, for slurmdbd
    mariadb-install-db --no-defaults --datadir="$DIR/mysql" --user="$user" \
        --auth-root-authentication-method=socket --skip-test-db > "$DIR/log/mariadb-install.out" 2>&1 \
        || die "mariadb-install-db failed (see $DIR/log/mariadb-install.out)"
    local db_socket="$DIR/mysql.sock"
    launch mariadbd mariadbd --no-defaults --datadir="$DIR/mysql" --socket="$db_socket" \
        --port="$db_port" --bind-address=127.0.0.1 --skip-name-resolve --user="$user" \
        --log-error="$DIR/log/mariadb.log" --innodb-buffer-pool-size=64M
    wait_for 30 mariadbd mariadb-admin --no-defaults --socket="$db_socket" -u root ping
    mariadb --no-defaults --socket="$db_socket" -u root -e "
        CREATE USER 'slurm'@'127.0.0.1' IDENTIFIED BY '$db_pass';
        GRANT ALL ON slurm_acct_db.* TO 'slurm'@'127.0.0.1';"

    # --- SLURM configuration
    cat > "$DIR/etc/slurm.conf" <<EOF
ClusterName=$CLUSTER
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=$user
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$munge_socket
CryptoType=crypto/munge
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/state/slurmctld.pid
SlurmdPidFile=$DIR/spool/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
JobAcctGatherType=jobacct_gather/linux
JobAcctGatherFrequency=task=1
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=127.0.0.1
AccountingStoragePort=$dbd_port
AccountingStoragePass=$munge_socket
AccountingStorageEnforce=associations,limits
AccountingStoreFlags=job_comment
JobCompType=jobcomp/none
MinJobAge=600
NodeName=$host NodeAddr=127.0.0.1 NodeHostname=$host CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=$PARTITION Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
    cat > "$DIR/etc/slurmdbd.conf" <<EOF
AuthType=auth/munge
AuthInfo=socket=$munge_socket
DbdHost=$host
DbdAddr=127.0.0.1
DbdPort=$dbd_port
SlurmUser=$user
PidFile=$DIR/state/slurmdbd.pid
LogFile=$DIR/log/slurmdbd.log
StorageType=accounting_storage/mysql
StorageHost=127.0.0.1
StoragePort=$db_port
StorageUser=slurm
StoragePass=$db_pass
StorageLoc=slurm_acct_db
EOF
    chmod 600 "$DIR/etc/slurmdbd.conf"
    export SLURM_CONF="$DIR/etc/slurm.conf"

    # --- accounting: slurmdbd, then the cluster, an account and this user in it
    launch slurmdbd slurmdbd -D
    wait_for 30 slurmdbd sacctmgr -n list cluster
    sacctmgr -i add cluster "$CLUSTER" > /dev/null
    sacctmgr -i add account "$ACCOUNT" Cluster="$CLUSTER" Description=tests Organization=tyreroad > /dev/null
    sacctmgr -i add user "$user" Account="$ACCOUNT" Cluster="$CLUSTER" > /dev/null

    # --- controller and the one compute node
    launch slurmctld slurmctld -D -c
    wait_for 30 slurmctld scontrol ping
    launch slurmd slurmd -D -N "$host"
    wait_for 30 "node $host" bash -c "sinfo -h -n '$host' -o %T | grep -qx idle"

    # snakemake-executor-plugin-slurm-jobstep drops every SLURM_* variable but the job's identity
    # before its nested srun, SLURM_CONF included, so inside a job srun would look for the system's
    # /etc/slurm/slurm.conf. Clients of this cluster find an srun that restores it first in DIR/bin.
    mkdir -p "$DIR/bin"
    printf '#!/bin/sh\nSLURM_CONF=%s exec %s "$@"\n' "$DIR/etc/slurm.conf" "$(command -v srun)" > "$DIR/bin/srun"
    chmod 755 "$DIR/bin/srun"

    cat > "$DIR/env" <<EOF
SLURM_CONF=$DIR/etc/slurm.conf
SLURM_BIN_DIR=$DIR/bin
SLURM_ACCOUNT_NAME=$ACCOUNT
SLURM_PARTITION_NAME=$PARTITION
EOF
    trap - EXIT
    echo "cluster.sh: SLURM cluster '$CLUSTER' up in $((SECONDS - t_start)) s: node $host ($cpus CPUs, $mem_mb MB)," \
        "partition $PARTITION, account $ACCOUNT; export SLURM_CONF=$DIR/etc/slurm.conf PATH=$DIR/bin:\$PATH" >&2
    cat "$DIR/env"
}

[ $# = 2 ] || usage
DIR=$(realpath -m "$2")
case "$1" in
    start) start ;;
    stop) export PATH="$PATH:/usr/sbin:/sbin"; stop_daemons ;;
    *) usage ;;
esac
