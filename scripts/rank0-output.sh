#!/usr/bin/env bash
# Run a command under mpirun with only rank 0 writing to the console; the
# other ranks write to $RANK_LOG_DIR/rank-N.log (shown by `make test` on failure).
rank=${OMPI_COMM_WORLD_RANK:-${PMI_RANK:-0}}
if [ "$rank" = 0 ]; then
  exec "$@"
fi
dir=${RANK_LOG_DIR:-.cache}
mkdir -p "$dir"
exec "$@" > "$dir/rank-$rank.log" 2>&1
