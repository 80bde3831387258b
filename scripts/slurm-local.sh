#!/usr/bin/env bash
# A real single-node Slurm cluster on this machine, for trying `scanbench run --executor slurm`
# and for the tests (tests/harness/test_slurm.cpp). Debian 12 (slurm-wlm 22.05, munge); as root,
# without systemd.
#
#   scripts/slurm-local.sh start    install slurm-wlm, slurm-client and munge if missing, write
#                                   the config, start munged (unless one answers already),
#                                   slurmctld and slurmd; wait until the node is idle
#   scripts/slurm-local.sh stop     stop the daemons this script started (by their PIDs)
#   scripts/slurm-local.sh status   the daemons, the node and the queue
#   scripts/slurm-local.sh env      print `export SLURM_CONF=...` (eval it to use the cluster)
#
# Everything lives in one folder of its own, $SCANBENCH_SLURM_DIR (default /tmp/scanbench-slurm):
# slurm.conf, spool and state folders (owned by the slurm user), logs and the daemons' PIDs.
# /etc/slurm is never touched; the client commands find the cluster through SLURM_CONF. The
# controller listens on $SCANBENCH_SLURM_PORT (default 16817) and slurmd on the next port, so a
# Slurm already set up on the machine (6817/6818) is left alone.
#
# The node: NodeName=localhost at 127.0.0.1 whose NodeHostname is this machine's `hostname` and
# whose CPUs, sockets, cores, threads and memory come from `slurmd -C`. No cgroups
# (ProctrackType=proctrack/linuxproc, TaskPlugin=task/none; a cgroup.conf with
# CgroupPlugin=disabled is not valid in 22.05 and stops slurmd), no accounting database
# (AccountingStorageType=accounting_storage/none: sacct does not work, squeue and scontrol do).
set -euo pipefail

dir="${SCANBENCH_SLURM_DIR:-/tmp/scanbench-slurm}"
port="${SCANBENCH_SLURM_PORT:-16817}"
conf="$dir/slurm.conf"
export SLURM_CONF="$conf"

die() {
  echo "slurm-local: $*" >&2
  exit 1
}

need_root() {
  [[ $(id -u) -eq 0 ]] || die "must run as root (it starts slurmd and munged); try: sudo $0 $1"
}

install_packages() {
  local missing=()
  for p in slurm-wlm slurm-client munge; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  ((${#missing[@]})) || return 0
  echo "slurm-local: installing ${missing[*]}"
  command -v apt-get >/dev/null || die "apt-get not found: install ${missing[*]} by hand"
  apt-get update -qq || die "apt-get update failed"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" \
    >"$dir/apt.log" 2>&1 || die "apt-get install ${missing[*]} failed (see $dir/apt.log)"
}

# Runs "$@" without this script's descriptors above 2: a daemon that inherited a lock or a pipe
# (this script's lock, a caller's build lock, a test's popen pipe) would hold it as long as it runs.
closing_fds() {
  bash -c 'for f in /proc/$$/fd/*; do n=${f##*/}; if ((n > 2)); then eval "exec $n>&-"; fi; done 2>/dev/null; exec "$@"' _ "$@"
}

pid_alive() { [[ -f "$1" ]] && kill -0 "$(cat "$1")" 2>/dev/null; }

munge_answers() { munge -n 2>/dev/null | unmunge >/dev/null 2>&1; }

start_munge() {
  if munge_answers; then
    return 0 # somebody's munged (or ours from an earlier start) answers: use it
  fi
  [[ -s /etc/munge/munge.key ]] || {
    # The package's postinst creates the key; create one if it did not.
    mungekey --create --keyfile=/etc/munge/munge.key 2>/dev/null ||
      dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
    chown munge:munge /etc/munge/munge.key
    chmod 0400 /etc/munge/munge.key
  }
  mkdir -p /run/munge /var/log/munge /var/lib/munge
  chown munge:munge /run/munge /var/log/munge /var/lib/munge
  chmod 0755 /run/munge
  closing_fds runuser -u munge -- /usr/sbin/munged </dev/null >/dev/null 2>&1 || die "munged did not start"
  for _ in $(seq 50); do
    munge_answers && break
    sleep 0.1
  done
  munge_answers || die "munged does not answer (see /var/log/munge/munged.log)"
  cp /run/munge/munged.pid "$dir/munged.pid" # ours: `stop` ends it
}

write_conf() {
  local host node
  host="$(hostname)"
  # "NodeName=vm CPUs=2 Boards=1 SocketsPerBoard=1 CoresPerSocket=2 ThreadsPerCore=1
  #  RealMemory=24105" -> the fields after the name.
  node="$(slurmd -C | head -1 | sed -e 's/^NodeName=[^ ]* //')"
  [[ $node == *CPUs=* ]] || die "slurmd -C printed no node description"
  cat >"$conf.tmp" <<EOF
# Written by scanbench's scripts/slurm-local.sh: a single-node cluster on $host.
ClusterName=scanbench
SlurmctldHost=$(hostname -s)(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=slurm
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool/slurmd
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$dir/log/jobcomp.txt
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MaxArraySize=100001
MaxJobCount=200000
SchedulerParameters=sched_interval=1
ReturnToService=2
KillWait=10
MinJobAge=300
MpiDefault=none
NodeName=localhost NodeAddr=127.0.0.1 NodeHostname=$host $node State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
  mv "$conf.tmp" "$conf"
}

node_state() { sinfo -h -n localhost -o %t 2>/dev/null | head -1; }

start() {
  need_root start
  mkdir -p "$dir"
  exec 9>"$dir/.lock"
  flock 9
  install_packages
  if pid_alive "$dir/slurmctld.pid.ours" && pid_alive "$dir/slurmd.pid.ours" &&
    [[ $(node_state) == idle* || $(node_state) == mix* || $(node_state) == alloc* ]]; then
    echo "slurm-local: already running (SLURM_CONF=$conf)"
    return 0
  fi
  mkdir -p "$dir/state" "$dir/spool/slurmd" "$dir/log"
  chown -R slurm:slurm "$dir/state" "$dir/log"
  chmod 0755 "$dir" "$dir/spool"
  start_munge
  write_conf
  if ! pid_alive "$dir/slurmctld.pid.ours"; then
    # setsid + closing_fds + redirections: the daemons outlive this script and hold none of its
    # descriptors. setsid does not fork here (not a group leader), so $! is the daemon's PID.
    setsid bash -c 'for f in /proc/$$/fd/*; do n=${f##*/}; if ((n > 2)); then eval "exec $n>&-"; fi; done 2>/dev/null; exec "$@"' _ \
      /usr/sbin/slurmctld -D -f "$conf" </dev/null >>"$dir/log/slurmctld.out" 2>&1 &
    echo $! >"$dir/slurmctld.pid.ours"
  fi
  if ! pid_alive "$dir/slurmd.pid.ours"; then
    setsid bash -c 'for f in /proc/$$/fd/*; do n=${f##*/}; if ((n > 2)); then eval "exec $n>&-"; fi; done 2>/dev/null; exec "$@"' _ \
      /usr/sbin/slurmd -D -N localhost -f "$conf" </dev/null >>"$dir/log/slurmd.out" 2>&1 &
    echo $! >"$dir/slurmd.pid.ours"
  fi
  local state=""
  for _ in $(seq 120); do
    state="$(node_state)"
    [[ $state == idle* || $state == mix* || $state == alloc* ]] && break
    pid_alive "$dir/slurmctld.pid.ours" || die "slurmctld exited: $(tail -3 "$dir/log/slurmctld.log" "$dir/log/slurmctld.out" 2>/dev/null | tr '\n' ' ')"
    pid_alive "$dir/slurmd.pid.ours" || die "slurmd exited: $(tail -3 "$dir/log/slurmd.log" "$dir/log/slurmd.out" 2>/dev/null | tr '\n' ' ')"
    sleep 0.5
  done
  [[ $state == idle* || $state == mix* || $state == alloc* ]] ||
    die "node not idle after 60 s (state '${state:-none}'; logs in $dir/log)"
  echo "slurm-local: running, node localhost $state (use: export SLURM_CONF=$conf)"
}

stop_pid() {
  local file="$1" name="$2"
  [[ -f $file ]] || return 0
  local pid
  pid="$(cat "$file")"
  if kill -0 "$pid" 2>/dev/null; then
    kill -TERM "$pid"
    for _ in $(seq 100); do
      kill -0 "$pid" 2>/dev/null || break
      sleep 0.1
    done
    kill -0 "$pid" 2>/dev/null && kill -KILL "$pid"
    echo "slurm-local: stopped $name ($pid)"
  fi
  rm -f "$file"
}

stop() {
  need_root stop
  [[ -d $dir ]] || return 0
  exec 9>"$dir/.lock"
  flock 9
  stop_pid "$dir/slurmd.pid.ours" slurmd
  stop_pid "$dir/slurmctld.pid.ours" slurmctld
  stop_pid "$dir/munged.pid" munged
}

status() {
  local up=0
  for d in slurmctld slurmd; do
    if pid_alive "$dir/$d.pid.ours"; then
      echo "$d: running ($(cat "$dir/$d.pid.ours"))"
    else
      echo "$d: stopped"
      up=1
    fi
  done
  if munge_answers; then echo "munge: answers"; else echo "munge: does not answer"; up=1; fi
  if ((up == 0)); then
    sinfo -N -o "%N %t %c %m %P" || up=1
    squeue || up=1
  fi
  return $up
}

case "${1:-}" in
  start) start ;;
  stop) stop ;;
  status) status ;;
  env) echo "export SLURM_CONF=$conf" ;;
  *)
    echo "usage: $0 start|stop|status|env" >&2
    exit 2
    ;;
esac
