#!/bin/sh
# A stand-in for a user's inpainting program, speaking the `command` protocol of
# inpaint_background: reads INPUT/<stem>.png + INPUT/<stem>_mask.png, writes
# OUTPUT/<stem>.png. Modes exercise the adapter's success and failure paths.
#   ok          write the mask itself as the "filled" image (white inside the hole)
#   fail        complain on stderr and exit 3
#   hang        never finish (the adapter must kill it)
#   hang_with_helper  start a helper process (its pid in WORKDIR/helper.pid), then
#               never finish: the adapter must kill the helper too
#   missing     exit 0 without writing anything
#   wrong_size  write FILE (4th argument) as every output
#   args        print each argument on stderr, then exit 1
mode="$1"; input="$2"; output="$3"
# One output per input mask: the file given as $1, or else the mask itself.
write_outputs() {
  for mask in "$input"/*_mask.png; do
    cp "${1:-$mask}" "$output/$(basename "$mask" _mask.png).png"
  done
}
case "$mode" in
  ok)
    write_outputs ;;
  fail)
    echo "model weights not found: /models/inpaint.ckpt" >&2
    exit 3 ;;
  hang)
    echo "loading model..." >&2
    exec sleep 30 ;;
  hang_with_helper)
    sleep 30 &
    echo $! > "$input/../helper.pid"
    echo "started helper" >&2
    wait ;;
  missing)
    exit 0 ;;
  wrong_size)
    write_outputs "$4" ;;
  args)
    for a in "$@"; do echo "arg:[$a]" >&2; done
    exit 1 ;;
  *)
    echo "unknown mode $mode" >&2
    exit 2 ;;
esac
