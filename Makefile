# Convenience wrappers around ./dev (which needs no make).
.PHONY: demo test setup bench
demo: ; ./dev demo
test: ; ./dev test
setup: ; ./dev setup
bench: ; ./dev bench
