# The literate manuscript paper/paper.md -> one self-contained HTML file (figures embedded).
# Numbers in the text are placeholders {{fig8.<key>}} / {{config.<dotted key>}} filled from
# results/summary/*.json and results/config.json by scripts/paper/build_paper.py.


rule paper:
    input:
        md="paper/paper.md",
        # the markdown renderer (build_paper.py itself is tracked as the rule's script)
        renderer=f"{WF_LIB}/mdrender.py",
        config=f"{R}/config.json",
        figures=expand(f"{R}/figures/{{name}}.png", name=FIGURES),
        tables=expand(f"{R}/tables/{{name}}.md", name=TABLES),
        summaries=expand(f"{R}/summary/{{fig}}.json", fig=SUMMARIZED) + EXTRA_SUMMARIES,
        stress=(f"{R}/stress-quick/summary.md" if config.get("stress_profile", "full") == "quick"
                else f"{R}/stress/summary.md"),
        # the accuracy suite's table (Section 4): the quick profile unless accuracy_profile is full
        accuracy=(f"{R}/accuracy/summary.md" if config.get("accuracy_profile", "quick") == "full"
                  else f"{R}/accuracy-quick/summary.md"),
        # the Performance section (rule bench_report; absent without a `benchmarks` config)
        benchmarks=([f"{R}/benchmarks/summary.md", f"{R}/benchmarks/workprecision.png"]
                    + ([f"{R}/benchmarks/scaling.png"] if "scaling" in config["benchmarks"]["standalone"] else [])
                    if config.get("benchmarks") else []),
    output:
        html=f"{R}/paper/paper.html",
        md=f"{R}/paper/paper.filled.md",
    log:
        f"{R}/logs/paper.log",
    benchmark:
        f"{R}/logs/times/paper.tsv",
    threads: 1
    priority: 10
    resources:
        mem_mb=500,
        runtime=5,
    script:
        "../scripts/paper/build_paper.py"
