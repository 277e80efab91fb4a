# Sourced by the GPU scripts that run the shipped walks (tools/gpu-pacing.sh, tools/gpu-cluster.sh):
# the scene each walk of config/paths/<scene>-walk.toml goes through, as `vlf generate` makes it.
generate() {  # scene name -> the generator's command line
  case $1 in
    classroom-100k) echo "classroom --size 100000 --mirrors" ;;
    classroom-1m) echo "classroom --size 1000000 --mirrors" ;;
    gallery) echo "gallery --mirrors" ;;
    # the 100K classroom with glossy floors and metal (issue 29), on the 100K classroom's walk
    classroom-100k-glossy) echo "classroom --size 100000 --mirrors --glossy" ;;
  esac
}
walk_path() {  # scene name -> its walk, config/paths/<walk>-walk.toml
  case $1 in
    classroom-100k-glossy) echo "$PWD/config/paths/classroom-100k-walk.toml" ;;
    *) echo "$PWD/config/paths/$1-walk.toml" ;;
  esac
}
