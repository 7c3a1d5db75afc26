"""The error model: effects, identification, learned predictors, explaining (``diagnose``) and
validating it against measurements."""
