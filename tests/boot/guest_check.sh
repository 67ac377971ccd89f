#!/bin/bash
# The booted guest's check (tests/boot/run.sh): run by mm-boot-check.service once the system is
# up. Prints "CHECK <name> PASS|FAIL <detail>" lines and "GUEST done" on the serial console,
# then powers the guest off.
set -u
export SYSTEMD_PAGER=
# The console may still hold the firmware's escape codes on its current line: start a fresh one.
echo
echo "GUEST up $(uname -r), systemd $(systemctl --version | head -1 | cut -d' ' -f2)"
check() {  # check NAME CONDITION-EXIT-STATUS DETAIL
  if [ "$2" -eq 0 ]; then echo "CHECK $1 PASS $3"; else echo "CHECK $1 FAIL $3"; fi
}
finish() {
  for core in /var/lib/monomesh/core.*; do  # MM_BOOT_DEBUG: a crash's backtrace.
    [ -f "$core" ] && command -v gdb >/dev/null || continue
    gdb -batch -ex 'info threads' -ex 'thread apply all bt 25' /usr/bin/monomeshd "$core" 2>&1 |
      grep -v '^\[New LWP' | sed 's/^/GUEST gdb: /' | head -n 200
  done
  echo "GUEST journal of monomeshd (last 40 lines):"
  journalctl -u monomeshd --no-pager -o cat | tail -n 40 | sed 's/^/GUEST   /'
  echo "GUEST journal of monomesh-web (last 20 lines):"
  journalctl -u monomesh-web --no-pager -o cat | tail -n 20 | sed 's/^/GUEST   /'
  echo "GUEST done"
  systemctl poweroff --no-block
  exit 0
}

# 1. systemd started the installed unit (enabled as the README says), and it reports ready.
state=inactive
for _ in $(seq 1 240); do
  state=$(systemctl is-active monomeshd.service)
  [ "$state" = active ] && break
  sleep 1
done
check unit_active "$([ "$state" = active ]; echo $?)" "monomeshd.service is $state"
[ "$state" = active ] || finish

# 2. It runs as the package's user, under the unit's sandbox.
pid=$(systemctl show -p MainPID --value monomeshd.service)
user=$(ps -o user= -p "$pid" | tr -d ' ')
check runs_as_monomesh "$([ "$user" = monomesh ]; echo $?)" "main pid $pid runs as '$user'"
exposure=$(systemd-analyze security monomeshd.service 2>/dev/null | sed -n 's/.*Overall exposure level for monomeshd.service: \([0-9.]*\).*/\1/p')
check exposure "$(awk -v e="${exposure:-99}" 'BEGIN { exit !(e <= 2.0) }'; echo $?)" \
  "systemd-analyze security on the booted unit: ${exposure:-unknown}"

# 3. A user in group monomesh, not root, presses capture and gets an entry in the spool the
# config names (the example config's default, inside the unit's StateDirectory).
spool=/var/lib/monomesh/spool
grep -q '^dir = "/var/lib/monomesh/spool"' /etc/monomesh/monomeshd.toml
check config_spool $? "/etc/monomesh/monomeshd.toml names $spool"
groups_of_operator=$(id -nG operator)
check operator_not_root "$([ "$(id -u operator)" -ne 0 ] && [[ " $groups_of_operator " == *" monomesh "* ]]; echo $?)" \
  "operator: uid $(id -u operator), groups $groups_of_operator"
status=$(runuser -u operator -- monomesh ctl status 2>&1)
check operator_status "$(echo "$status" | grep -q '"ok": true'; echo $?)" \
  "ctl status as operator: $(echo "$status" | grep -m1 '"state"' | tr -d ' ,')"
start=$SECONDS
result=$(runuser -u operator -- monomesh ctl trigger --wait 600 2>&1)
rc=$?
entry=$(echo "$result" | sed -n 's/.*"entry": "\([^"]*\)".*/\1/p' | head -1)
check operator_trigger "$rc" "ctl trigger --wait as operator: exit $rc after $((SECONDS - start)) s, entry ${entry:-none}"
[ -n "$entry" ] || { echo "$result" | sed 's/^/GUEST   /'; finish; }
case "$entry" in "$spool"/*) in_spool=0 ;; *) in_spool=1 ;; esac
check entry_in_configured_spool "$in_spool" "$entry"
missing=""
for f in mesh.glb mesh.obj mesh.ply texture.jpg keyframe_b.jpg report.json preview.png; do
  runuser -u operator -- test -r "$entry/$f" || missing="$missing $f"
done
check entry_whole_and_readable "$([ -z "$missing" ]; echo $?)" \
  "files readable by operator, missing:${missing:- none}"
latest=$(readlink "$spool/latest")
check latest_symlink "$([ "$spool/$latest" = "$entry" ]; echo $?)" "latest -> $latest"
report=$(runuser -u operator -- monomesh report "$entry" 2>&1 | grep -m1 '^success ')
check operator_reads_report "$([ "$report" = "success true" ]; echo $?)" "monomesh report: $report"
# Nothing the unit may not write was written: the daemon's files are its spool and its socket.
stray=$(find / -xdev -user monomesh -newer /etc/monomesh/monomeshd.toml \
          -not -path '/var/lib/monomesh' -not -path '/var/lib/monomesh/*' -not -path '/run/monomesh' \
          -not -path '/run/monomesh/*' -not -path '/proc/*' \
          -not -path '/var/lib/private/*' -not -path '/tmp/*' -not -path '/var/tmp/*' 2>/dev/null | head -5)
check writes_only_its_state "$([ -z "$stray" ]; echo $?)" "files of user monomesh elsewhere: ${stray:-none}"
errors=$(journalctl -u monomeshd -p err --no-pager -o cat | head -5)
check no_errors_logged "$([ -z "$errors" ]; echo $?)" "${errors:-journal has no error of monomeshd}"

# 4. The web page's unit (monomesh-web.service, enabled as the README says): its own user,
# its sandbox, the API on 127.0.0.1:8080, captures only with the token the package made.
web=inactive
for _ in $(seq 1 60); do
  web=$(systemctl is-active monomesh-web.service)
  [ "$web" = active ] && break
  sleep 1
done
check web_unit_active "$([ "$web" = active ]; echo $?)" "monomesh-web.service is $web"
web_pid=$(systemctl show -p MainPID --value monomesh-web.service)
web_user=$(ps -o user= -p "$web_pid" | tr -d ' ')
check web_runs_as_its_user "$([ "$web_user" = monomesh-web ]; echo $?)" "main pid $web_pid runs as '$web_user'"
web_exposure=$(systemd-analyze security monomesh-web.service 2>/dev/null | sed -n 's/.*Overall exposure level for monomesh-web.service: \([0-9.]*\).*/\1/p')
check web_exposure "$(awk -v e="${web_exposure:-99}" 'BEGIN { exit !(e <= 2.5) }'; echo $?)" \
  "systemd-analyze security on the booted unit: ${web_exposure:-unknown}"
token_mode=$(stat -c '%U:%G %a' /etc/monomesh/web-token 2>&1)
check web_token_made "$([ "$token_mode" = "root:monomesh 640" ]; echo $?)" "/etc/monomesh/web-token: $token_mode"
api=http://127.0.0.1:8080
web_status=$(curl -s -m 5 "$api/api/status")
check web_status "$(echo "$web_status" | grep -q '"state":"idle"'; echo $?)" "GET /api/status: $(echo "$web_status" | head -c 80)"
listed=$(curl -s -m 5 "$api/api/entries" | grep -o '"name":"[^"]*"' | head -1)
check web_lists_entry "$([ "$listed" = "\"name\":\"$(basename "$entry")\"" ]; echo $?)" "GET /api/entries: newest $listed"
glb=$(curl -s -m 10 -o /dev/null -w '%{http_code} %{size_download}' "$api/api/entries/$(basename "$entry")/mesh.glb")
check web_serves_mesh "$([ "${glb%% *}" = 200 ] && [ "${glb##* }" -gt 1000 ]; echo $?)" "GET mesh.glb: $glb"
three=$(curl -s -m 10 -o /dev/null -w '%{http_code}' "$api/three/build/three.module.js")
check web_serves_three "$([ "$three" = 200 ]; echo $?)" "GET /three/build/three.module.js: $three (libjs-three)"
refused=$(curl -s -m 5 -o /dev/null -w '%{http_code}' -d '' "$api/api/trigger")
check web_post_needs_token "$([ "$refused" = 401 ]; echo $?)" "POST /api/trigger without the token: $refused"
before=$(find "$spool" -maxdepth 1 -name '2*' | wc -l)
pressed=$(runuser -u operator -- sh -c "curl -s -m 10 -d '' -H \"Authorization: Bearer \$(cat /etc/monomesh/web-token)\" $api/api/trigger")
after=$before
for _ in $(seq 1 600); do
  after=$(find "$spool" -maxdepth 1 -name '2*' | wc -l)
  [ "$after" -gt "$before" ] && break
  sleep 1
done
check web_capture_with_token "$([ "$after" -gt "$before" ]; echo $?)" \
  "POST /api/trigger with the token (read by operator): $pressed; entries $before -> $after"
web_stray=$(find / -xdev -user monomesh-web -not -path '/proc/*' 2>/dev/null | head -5)
check web_writes_nothing "$([ -z "$web_stray" ]; echo $?)" "files of user monomesh-web: ${web_stray:-none}"

# 5. Stopping is clean: the unit stops within its timeout and leaves no entry half-written.
systemctl stop monomeshd.service
result=$(systemctl show -p Result --value monomeshd.service)
tmp=$(find "$spool" -maxdepth 1 -name '.tmp-*' | head -1)
check clean_stop "$([ "$result" = success ] && [ -z "$tmp" ]; echo $?)" "Result=$result, leftovers: ${tmp:-none}"
finish
