#!/usr/bin/env bash
# Every tool's command line goes through CLI11: --help prints the generated usage and exits 0; an
# unknown option, a missing required value or a bad number exits 2 with one line naming it and a
# pointer to --help; values keep their meaning (a negative number is a value, lists split on
# commas). Nothing here does the tools' work but one short corridor evaluation.
# And lcd_evaluate --gt-mat reads a MATLAB v7.3 (HDF5) file (written by WRITE_MAT73_FIXTURE).
#   command_lines.sh TOOLS_DIR WRITE_MAT73_FIXTURE
set -euo pipefail
tools="$1" write_mat73="$2"
folder="$(mktemp -d)"
trap 'rm -rf "$folder"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# expect CODE PATTERN TOOL ARGS...: the tool exits CODE and its output matches PATTERN.
expect() {
  local code="$1" pattern="$2" tool="$3"
  shift 3
  local got=0
  "$tools/$tool" "$@" > "$folder/out.txt" 2>&1 || got=$?
  if [ "$got" != "$code" ]; then
    fail "$tool $*: exit $got, not $code"; sed 's/^/    /' "$folder/out.txt" | head -5
  elif ! grep -qE -- "$pattern" "$folder/out.txt"; then
    fail "$tool $*: no '$pattern' in"; sed 's/^/    /' "$folder/out.txt" | head -5
  fi
}

# The arguments a tool requires, so that the unknown option is what it reports.
declare -A required=(
  [lcd_bench_save]="--map a.map --copy b.map" [lcd_bench_pipeline]="--database a --queries b"
  [lcd_db]="info a.map" [lcd_config]="check a.yaml" [lcd_train]="broad" [make_demo_bag]="a.bag")
for tool in lcd_bench_fleet lcd_bench_scaling lcd_bench_network lcd_bench_pose_graph lcd_bench_map \
    lcd_bench_save lcd_bench_pipeline lcd_bench_verification lcd_bench_store lcd_bench_markers \
    lcd_db lcd_config lcd_evaluate lcd_train make_demo_bag; do
  expect 0 "Usage: .*$tool" "$tool" --help
  # shellcheck disable=SC2086
  expect 2 "The following argument was not expected: --no-such-option" \
    "$tool" ${required[$tool]:-} --no-such-option
  # shellcheck disable=SC2086
  expect 2 "Run with --help for more information" "$tool" ${required[$tool]:-} --no-such-option
done

# Options each tool documents, by name, in its --help.
expect 0 "--gt-mat" lcd_evaluate --help
expect 0 "IN DETAIL" lcd_evaluate --help
expect 0 "--checkpoints" lcd_bench_fleet --help
expect 0 "check" lcd_config --help
expect 0 "--components" lcd_train whitening --help
expect 0 "--enhancement" lcd_train broad --help
# Bad values, each named.
expect 2 "--robots" lcd_bench_fleet --robots 1
expect 2 "--robots" lcd_bench_fleet --robots many
expect 2 "--route" lcd_bench_map --route sideways
expect 2 "--map is required|--map" lcd_bench_save --copy "$folder/copy.map"
expect 2 "A subcommand is required|subcommand" lcd_db
expect 2 "MAP is required|MAP" lcd_db info
expect 2 "files is required|files" lcd_config check
expect 2 "--gt-mat" lcd_evaluate --gt-mat
expect 2 "--descriptor" lcd_bench_pipeline --database a --queries b --descriptor nonsense
# lcd_config's subcommands do their work.
expect 0 "min_score" lcd_config defaults
printf 'mode: mapping\n' > "$folder/ok.yaml"
expect 0 "ok.yaml: ok" lcd_config check "$folder/ok.yaml"
printf 'no_such_key: 1\n' > "$folder/bad.yaml"
expect 1 "no_such_key is not a parameter" lcd_config check "$folder/bad.yaml"
# A parameter file of the layout before `advanced/` (the shipped default.yaml of then): it loads,
# and check names where each of its keys went, every one of them.
before="$(dirname "$0")/default_before_tiers.yaml"
expect 1 "keyframe/min_motion moved: it is now advanced/keyframe/min_motion" lcd_config check "$before"
moved=$(grep -c " moved: it is now advanced/" "$folder/out.txt" || true)
fixed=$(grep -c "is ignored: it is fixed at its measured value" "$folder/out.txt" || true)
removed=$(( $(grep -c "is no longer a parameter of the node" "$folder/out.txt" || true) - fixed ))
# 92 keys moved under advanced/; 34 no longer read (measured and not kept, a network's
# preprocessing, now in its description, or online training, now lcd_train); 22 fixed at their
# measured values; 12 kept their names.
[ "$moved" -ge 90 ] || fail "lcd_config check named $moved moved keys of the earlier default.yaml"
[ "$removed" -eq 34 ] || fail "lcd_config check named $removed removed keys, not 34"
[ "$fixed" -eq 22 ] || fail "lcd_config check named $fixed fixed keys, not 22"
if grep -q "is not a parameter" "$folder/out.txt"; then
  fail "a key of the earlier default.yaml is reported unknown"; grep "is not a parameter" "$folder/out.txt"
fi
# A negative odometry error is a value, not an option; the range check after parsing still speaks.
expect 2 "scale error must be within" make_demo_bag "$folder/demo.bag" 1 10 -0.9 0.004
expect 2 "--two-robots takes OUTPUT" make_demo_bag --two-robots "$folder/demo.bag" 10 20
# lcd_evaluate: a dry run reads its options and stops.
expect 0 "corridor|dry run" lcd_evaluate --corridor 1 --detector --dry-run --output "$folder/results"
# The one evaluation here (9 s): each loop's distance from the truth is printed, binned to the
# true-loop rule's 2.5 m, none beyond it.
expect 0 "offset from the truth \(m, a loop is true within 2.50\): \[0.00,0.50\) [1-9][0-9]* .* beyond: 0" \
  lcd_evaluate --corridor 1.3 --detector --sweep-steps 0 --output "$folder/results"

# Ground truth saved by MATLAB with -v7.3 (HDF5): read, checked against the images, and its 3
# revisits found.
"$write_mat73" "$folder/v73"
head -c 19 "$folder/v73/truth_v73.mat" | grep -q "MATLAB 7.3 MAT-file" || fail "the fixture is no v7.3 file"
expect 0 "dry run: 6 database and 6 query images .*ground truth .*truth_v73.mat" lcd_evaluate \
  --images "$folder/v73/images" --gt-mat "$folder/v73/truth_v73.mat" --dry-run --output "$folder/r"
expect 0 "pixels +R@100P 1.000" lcd_evaluate --images "$folder/v73/images" --gt-mat "$folder/v73/truth_v73.mat" \
  --gt-var GT --descriptors pixels --exclude-recent 1 --output "$folder/r"
expect 1 "no 2-D numeric variable 'truth' \\(found: GT\\)" lcd_evaluate --images "$folder/v73/images" \
  --gt-mat "$folder/v73/truth_v73.mat" --gt-var truth --dry-run --output "$folder/r"

if [ "$failures" -gt 0 ]; then echo "$failures failure(s)"; exit 1; fi
echo "every tool's command line: ok"
