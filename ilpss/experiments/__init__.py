"""The paper's experiments on the drill: protocols A-C, runner, executors, reports, demo."""
