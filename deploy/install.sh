#!/usr/bin/env bash
# Install the robot stack on an Ubuntu/Debian robot (deploy/RUNBOOK.md). Idempotent; run as root.
#
#   sudo deploy/install.sh [--start]            install or update, enable the units
#   sudo deploy/install.sh --uninstall [--purge] remove units + code (--purge: also config,
#                                                state and the service users)
#
# Layout: code + one venv + built UI in /opt/robot-stack (root-owned, read-only to services),
# settings and secrets in /etc/robot-stack/<service>.env (0600 root:root: systemd reads them as
# root and hands each service only its own; secrets generated once, never overwritten), state in
# /var/lib/<unit> (systemd StateDirectory), units in /etc/systemd/system, all started by
# robot-stack.target. Each service runs as its own system user (named like its unit), so a
# compromised service can read neither another's env file nor its /proc/<pid>/environ.
#
# DESTDIR=/some/dir installs into a throwaway root instead (used by tests/deploy): no root
# needed, and user/ownership/systemctl commands are written to $DESTDIR/install-actions.log
# instead of being run. --skip-build leaves out the venv and UI build (uv sync, cmake, npm).
set -euo pipefail

APP=robot-stack
# One entry per service: "<unit> <env files it reads>". The unit runs as a system user named
# like the unit; deploy/<unit>.service must name the same user and the same env files. Adding
# a service = its unit file + one line here (its env files are created empty, 0600 root; give
# them generated secrets in write_env_files).
SERVICES=(
  "robot-mcp-perception ros vision"
  "mcp-skill-control ros skill-control"
  "mcp-perception-buffer ros perception-buffer"
  "robot-mcp-memory memory"
  "robot-mcp-navigation ros navigation"
  "robot-mcp-manipulation ros manipulation"
  "robot-mcp-episodic ros episodic"
  "robot-voice-chat brain"
  "robot-audio-listener ros audio-listener"
)
UNITS=()
for entry in "${SERVICES[@]}"; do UNITS+=("${entry%% *}"); done
# One entry per MCP server: "<its env file>:<NAME>". Each gets two credentials, generated once:
# the brain's (MCP_AUTH_TOKEN there, <NAME>_MCP_TOKEN in brain.env) and the operators' tools'
# (MCP_OPERATOR_TOKEN there, <NAME>_MCP_OPERATOR_TOKEN in operator.env, which no unit reads).
MCP_SERVERS=(
  "skill-control:SKILL_CONTROL"
  "perception-buffer:PERCEPTION"
  "memory:MEMORY"
  "episodic:EPISODIC"
  "navigation:NAVIGATION"
  "manipulation:MANIPULATION"
)
# MCP servers that demand an operator's signed approval for some tools (memory.save_process,
# episodic forget): one approval secret each, generated once, shared with the brain only
# (MCP_APPROVAL_SECRET there, <NAME>_APPROVAL_SECRET in brain.env; robot_mcp_kit.approvals).
APPROVAL_SERVERS=(
  "memory:MEMORY"
  "episodic:EPISODIC"
)
LEGACY_USER=robot  # every unit ran as this one user before 0.x; removed by --purge
SOURCE="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DESTDIR="${DESTDIR:-}"
DESTDIR="${DESTDIR%/}"
OPT="$DESTDIR/opt/$APP"
ETC="$DESTDIR/etc/$APP"
SYSTEMD="$DESTDIR/etc/systemd/system"

mode=install purge=0 build=1 start=0
for arg in "$@"; do
  case "$arg" in
    --uninstall) mode=uninstall ;;
    --purge) purge=1 ;;
    --skip-build) build=0 ;;
    --start) start=1 ;;
    -h|--help) sed -n '2,17p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "install.sh: unknown argument $arg (see --help)" >&2; exit 2 ;;
  esac
done

say() { echo "install.sh: $*"; }
die() { echo "install.sh: error: $*" >&2; exit 2; }

# System changes (users, ownership, systemd): run for real, or recorded under DESTDIR.
system() {
  if [[ -n "$DESTDIR" ]]; then
    echo "$*" >>"$DESTDIR/install-actions.log"
  else
    "$@"
  fi
}

if [[ -z "$DESTDIR" ]]; then
  [[ $(id -u) -eq 0 ]] || die "run as root (sudo), or set DESTDIR for a throwaway root"
  command -v systemctl >/dev/null || die "systemd is required"
else
  mkdir -p "$DESTDIR"
fi

new_secret() { python3 -c 'import secrets; print(secrets.token_urlsafe(32))'; }

# value of KEY in an env file ("" when absent)
env_value() {
  [[ -f "$2" ]] || return 0
  sed -n "s/^$1=//p" "$2" | tail -n 1
}

# Append KEY=VALUE unless KEY is already there: re-runs keep operator edits and secrets.
ensure_key() {
  local file=$1 key=$2 value=$3
  grep -q "^$key=" "$file" 2>/dev/null || printf '%s=%s\n' "$key" "$value" >>"$file"
}

env_file() {  # name, then KEY=VALUE pairs
  local file="$ETC/$1.env" pair
  shift
  [[ -f "$file" ]] || { printf '# %s — read by systemd (as root) for the units that name it\n' \
    "$(basename "$file")" >"$file"; }
  for pair in "$@"; do ensure_key "$file" "${pair%%=*}" "${pair#*=}"; done
  # root only: systemd reads EnvironmentFile= before it drops to the service's user
  chmod 0600 "$file"
  system chown root:root "${file#"$DESTDIR"}"
}

install_users() {  # one system user per service (cameras/speaker: SupplementaryGroups= in units)
  local unit
  for unit in "${UNITS[@]}"; do
    if [[ -n "$DESTDIR" ]] || ! getent passwd "$unit" >/dev/null; then
      system useradd --system --user-group --home-dir "/var/lib/$unit" --no-create-home \
        --shell /usr/sbin/nologin "$unit"
    fi
  done
}

copy_tree() {  # the checkout's tracked + untracked-but-not-ignored files → $OPT (fresh copy)
  local staging="$OPT.new"
  rm -rf "$staging"
  mkdir -p "$staging"
  if git -C "$SOURCE" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    git -C "$SOURCE" ls-files -z --cached --others --exclude-standard \
      | tar -C "$SOURCE" --null --no-recursion --ignore-failed-read -T - -cf - \
      | tar -xf - -C "$staging"
  else
    tar -C "$SOURCE" --exclude=./.venv --exclude=./build --exclude=./.git \
      --exclude=node_modules -cf - . | tar -xf - -C "$staging"
  fi
  # keep the built venv and its interpreter across updates (re-synced below)
  local kept
  for kept in .venv .python; do
    if [[ -d "$OPT/$kept" ]]; then mv "$OPT/$kept" "$staging/$kept"; fi
  done
  rm -rf "$OPT"
  mv "$staging" "$OPT"
}

build_tree() {
  local uv
  uv="$(command -v uv || true)"
  [[ -n "$uv" ]] || uv="$HOME/.local/bin/uv"
  [[ -x "$uv" ]] || die "uv is not installed (python3 -m pip install uv), see RUNBOOK step 0"
  say "building the venv in $OPT/.venv (uv sync --frozen, no dev tools)"
  # The interpreter uv may download (the host's python3 is not 3.11) lives under /opt too:
  # the services cannot read root's home. Copies, not hardlinks into root's uv cache.
  (cd "$OPT" && UV_PROJECT_ENVIRONMENT="$OPT/.venv" UV_PYTHON_INSTALL_DIR="$OPT/.python" \
    UV_LINK_MODE=copy "$uv" sync --frozen --all-packages --inexact --no-group dev --quiet)
  VIRTUAL_ENV="$OPT/.venv" bash "$OPT/scripts/build-interfaces.sh"
  if [[ ! -f "$OPT/data/scenes/.complete" ]]; then
    "$OPT/.venv/bin/python" -m robot_mcp_perception.sample_scenes "$OPT/data/scenes"
    touch "$OPT/data/scenes/.complete"
  fi
  if [[ -f "$OPT/frontend/package.json" ]]; then
    command -v npm >/dev/null || die "npm is needed to build the UI (apt-get install nodejs npm)"
    say "building the UI (npm ci && npm run build)"
    (cd "$OPT/frontend" && npm ci --no-audit --no-fund --silent && npm run build --silent)
  else
    say "no frontend/ in this checkout: the brain serves its API only"
  fi
  chown -R root:root "$OPT"
}

write_env_files() {
  install -d -m 0700 "$ETC"
  chmod 0700 "$ETC"  # also when an older install made it 0750 root:robot
  system chown root:root "${ETC#"$DESTDIR"}"
  # One HMAC secret per event-posting server (navigation, manipulation, perception buffer),
  # shared with the brain; generated once. skill_control posts no events.
  local nav perc manip admin_key
  nav="$(env_value NAV_EVENT_SECRET "$ETC/brain.env")"
  nav="${nav:-$(env_value RVC_EVENT_SECRET "$ETC/navigation.env")}"
  nav="${nav:-$(new_secret)}"
  manip="$(env_value MANIP_EVENT_SECRET "$ETC/brain.env")"
  manip="${manip:-$(env_value RVC_EVENT_SECRET "$ETC/manipulation.env")}"
  manip="${manip:-$(new_secret)}"
  perc="$(env_value PERCEPTION_EVENT_SECRET "$ETC/brain.env")"
  perc="${perc:-$(env_value RVC_EVENT_SECRET "$ETC/perception-buffer.env")}"
  perc="${perc:-$(new_secret)}"
  admin_key="$(env_value ADMIN_SECRET_KEY "$ETC/brain.env")"
  admin_key="${admin_key:-$(new_secret)}"
  # The vision node's pictures (camera frame, masks, overlays) need a credential (issue 35):
  # ARTIFACTS_AUTH_TOKEN there, VISION_ARTIFACTS_TOKEN for the brain's camera proxy.
  local vision_token
  vision_token="$(env_value VISION_ARTIFACTS_TOKEN "$ETC/brain.env")"
  vision_token="${vision_token:-$(env_value ARTIFACTS_AUTH_TOKEN "$ETC/vision.env")}"
  vision_token="${vision_token:-$(new_secret)}"
  # argon2 hashes contain '$': single quotes keep systemd's env-file parser from touching them
  local quoted_hash=""
  [[ -n "${ADMIN_PASSWORD_HASH:-}" ]] && quoted_hash="'$ADMIN_PASSWORD_HASH'"

  env_file ros ROS_DOMAIN_ID=42 ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
  env_file vision GEMINI_API_KEY= PERCEPTION_CONFIG_OVERRIDES= "ARTIFACTS_AUTH_TOKEN=$vision_token"
  env_file skill-control LOG_LEVEL=INFO
  env_file perception-buffer "RVC_EVENT_SECRET=$perc" LOG_LEVEL=INFO
  # The robot's Nav2 drives the base (README "Deploying on a robot"); NAV_MAP is the robot's map
  # file of named places (default: the office sample map), NAV_MOTION=simulated for a dry run.
  # Supervision (issue 27): no motion without the brain's lease; the dead-man lock topic goes
  # into the robot's twist_mux (deploy/twist_mux/supervisor_lock.yaml, RUNBOOK "Supervision").
  env_file navigation "RVC_EVENT_SECRET=$nav" NAV_MOTION=nav2 NAV2_ACTION=/navigate_to_pose \
    NAV_POSE_TOPIC=/amcl_pose NAV_SUPERVISION=required NAV_LOCK_TOPIC=/robot/supervisor_lock \
    LOG_LEVEL=INFO
  # The robot's arm: its Pick/Place action servers (robot_manipulation_interfaces).
  env_file manipulation "RVC_EVENT_SECRET=$manip" MANIP_PICK_ACTION=/manipulation/pick \
    MANIP_PLACE_ACTION=/manipulation/place MANIP_HELD_TOPIC=/manipulation/held \
    MANIP_SUPERVISION=required MANIP_LOCK_TOPIC=/robot/supervisor_lock/manipulation LOG_LEVEL=INFO
  env_file memory "ROBOT_ID=$(hostname -s 2>/dev/null || echo robot-1)" LOG_LEVEL=INFO
  env_file episodic "ROBOT_ID=$(hostname -s 2>/dev/null || echo robot-1)" LOG_LEVEL=INFO
  env_file brain "NAV_EVENT_SECRET=$nav" "PERCEPTION_EVENT_SECRET=$perc" \
    "MANIP_EVENT_SECRET=$manip" "VISION_ARTIFACTS_TOKEN=$vision_token" \
    ADMIN_USERNAME=operator "ADMIN_PASSWORD_HASH=$quoted_hash" \
    "ADMIN_SECRET_KEY=$admin_key" ANTHROPIC_API_KEY= GROQ_API_KEY= OPENAI_API_KEY= \
    ROBOT_HOSTNAME=robot.local
  # the robot's microphone (issue 36): the operator's login for the brain, set by hand
  env_file audio-listener BRAIN_URL=http://127.0.0.1:8000 AUDIO_LISTENER_USERNAME=operator \
    AUDIO_LISTENER_PASSWORD= LOG_LEVEL=INFO
  write_mcp_credentials
  # every env file a SERVICES entry names exists (empty for a new service without settings)
  local entry name
  for entry in "${SERVICES[@]}"; do
    for name in ${entry#* }; do [[ -f "$ETC/$name.env" ]] || env_file "$name"; done
  done
  if [[ -z "$(env_value ADMIN_PASSWORD_HASH "$ETC/brain.env")" ]]; then
    say "set the operator password: /opt/$APP/.venv/bin/robot-voice-chat hash-password," \
      "then put it in /etc/$APP/brain.env as ADMIN_PASSWORD_HASH='<hash>' (single quotes)"
  fi
}

# No MCP server runs open (issue 27): each has its own credential for the brain and one for
# operators' tools (MCP Inspector, smoke.sh), kept across re-runs.
write_mcp_credentials() {
  local entry file name brain operator brain_pairs=() operator_pairs=()
  for entry in "${MCP_SERVERS[@]}"; do
    file="${entry%%:*}" name="${entry#*:}"
    brain="$(env_value "${name}_MCP_TOKEN" "$ETC/brain.env")"
    brain="${brain:-$(env_value MCP_AUTH_TOKEN "$ETC/$file.env")}"
    brain="${brain:-$(new_secret)}"
    operator="$(env_value "${name}_MCP_OPERATOR_TOKEN" "$ETC/operator.env")"
    operator="${operator:-$(env_value MCP_OPERATOR_TOKEN "$ETC/$file.env")}"
    operator="${operator:-$(new_secret)}"
    env_file "$file" "MCP_AUTH_TOKEN=$brain" "MCP_OPERATOR_TOKEN=$operator"
    brain_pairs+=("${name}_MCP_TOKEN=$brain")
    operator_pairs+=("${name}_MCP_OPERATOR_TOKEN=$operator")
  done
  local approval
  for entry in "${APPROVAL_SERVERS[@]}"; do
    file="${entry%%:*}" name="${entry#*:}"
    approval="$(env_value "${name}_APPROVAL_SECRET" "$ETC/brain.env")"
    approval="${approval:-$(env_value MCP_APPROVAL_SECRET "$ETC/$file.env")}"
    approval="${approval:-$(new_secret)}"
    env_file "$file" "MCP_APPROVAL_SECRET=$approval"
    brain_pairs+=("${name}_APPROVAL_SECRET=$approval")
  done
  env_file brain "${brain_pairs[@]}"
  [[ -f "$ETC/operator.env" ]] || printf '%s\n' "# operator.env — the MCP servers' credentials for \
operators' tools (MCP Inspector, smoke.sh; RUNBOOK); no unit reads it" >"$ETC/operator.env"
  env_file operator "${operator_pairs[@]}"
}

# Each unit runs as its own user and reads exactly the env files its SERVICES entry lists.
check_units() {
  local entry unit files listed named
  for entry in "${SERVICES[@]}"; do
    unit="${entry%% *}" files="${entry#* }"
    local path="$OPT/deploy/$unit.service"
    [[ -f "$path" ]] || die "$unit: no deploy/$unit.service"
    grep -qx "User=$unit" "$path" || die "$unit: deploy/$unit.service must set User=$unit"
    listed="$(for f in $files; do echo "/etc/$APP/$f.env"; done | sort)"
    named="$(sed -n 's/^EnvironmentFile=//p' "$path" | sort)"
    [[ "$listed" == "$named" ]] \
      || die "$unit: its EnvironmentFile= lines ($(echo $named)) are not its SERVICES entry's"
  done
}

install_units() {
  check_units
  install -d -m 0755 "$SYSTEMD"
  local unit
  for unit in "${UNITS[@]}"; do
    install -m 0644 "$OPT/deploy/$unit.service" "$SYSTEMD/$unit.service"
  done
  install -m 0644 "$OPT/deploy/$APP.target" "$SYSTEMD/$APP.target"
  # the TLS proxy joins the brain's group: only it may connect to the brain's proxy socket
  install -d -m 0755 "$SYSTEMD/caddy.service.d"
  install -m 0644 "$OPT/deploy/caddy-robot-stack.conf" "$SYSTEMD/caddy.service.d/$APP.conf"
  system systemctl daemon-reload
  system systemctl enable "$APP.target" "${UNITS[@]/%/.service}"
  if ((start)); then
    system systemctl restart "$APP.target"
  fi
}

uninstall() {
  local unit
  if [[ -z "$DESTDIR" ]]; then
    systemctl disable --now "$APP.target" "${UNITS[@]/%/.service}" 2>/dev/null || true
  else
    system systemctl disable --now "$APP.target" "${UNITS[@]/%/.service}"
  fi
  for unit in "${UNITS[@]}"; do rm -f "$SYSTEMD/$unit.service"; done
  rm -f "$SYSTEMD/$APP.target" "$SYSTEMD/caddy.service.d/$APP.conf"
  rmdir "$SYSTEMD/caddy.service.d" 2>/dev/null || true  # only if nothing else is in it
  system systemctl daemon-reload
  rm -rf "$OPT" "$OPT.new"
  if ((purge)); then
    rm -rf "$ETC"
    for unit in "${UNITS[@]}"; do rm -rf "$DESTDIR/var/lib/$unit"; done
    for unit in "${UNITS[@]}" "$LEGACY_USER"; do
      if [[ -n "$DESTDIR" ]] || getent passwd "$unit" >/dev/null; then
        system userdel "$unit"
      fi
    done
  fi
  say "uninstalled$( ((purge)) && echo ' (config, state and user purged)' || echo \
    "; kept /etc/$APP and /var/lib state (--purge removes them)")"
}

if [[ "$mode" == uninstall ]]; then
  uninstall
  exit 0
fi
install_users
copy_tree
if ((build)); then build_tree; else say "--skip-build: no venv/UI build"; fi
write_env_files
install_units
say "installed into ${DESTDIR:-/} — next: RUNBOOK.md step 3 (keys, operator password), then" \
  "systemctl start $APP.target && /opt/$APP/deploy/smoke.sh"
