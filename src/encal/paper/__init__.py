"""The paper's procedure: its studies (:mod:`~encal.paper.studies`), its HTML report
(:mod:`~encal.paper.report`) and the demo that runs them all (:mod:`~encal.paper.demo`)."""
