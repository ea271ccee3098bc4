"""The reproduction report (tools/reproduction_report.py is its command line), one module per concept:

- analysis:   the study analysis JSON (gel.study-analysis.v1) as read, and its accessors
- text:       numbers, Estimates and Markdown tables as printed
- figures:    the gnuplot figures and the `gelsim snapshot` pictures
- members:    the members' curve.json and structure.json, and the statistics tools over them
              (ensemble mean, trusted rows, log-log slope, seeded bootstrap)
- paper:      the published values of Seto et al. (2013) and the verdict rules
- comparison: each published statement held against the model, observable by observable
- report:     the Markdown page and the comparison JSON
"""
