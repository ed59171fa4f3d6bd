"""Front ends over the pipeline: the panolight command, batch runs, the evaluation protocol, the demo."""
