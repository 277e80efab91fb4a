vlf=.bin/vlf
$vlf propagate scenes/cornell-mirror/scene.toml -o /tmp/mirror.vlf 2>&1 | grep -E "propagation  "
$vlf cave config/displays/cave-4wall-walk.toml --scene /tmp/mirror.vlf --headless --frames 120 --out /tmp/cave-walk 2>&1 | grep -v XDG
$vlf cave config/displays/cave-4wall.toml --scene /tmp/mirror.vlf --headless --frames 60 --out /tmp/cave-static 2>&1 | grep "all views"
$vlf bench --scene scenes/cornell-mirror/scene.toml --frames 200 2>&1 | grep -E "render "
