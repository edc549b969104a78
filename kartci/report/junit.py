"""JUnit XML: one test case per scenario, one failure line per regressed or failed metric."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from kartci.report.tables import RUN, Wording, num
from kartci.results import ScenarioResult


def junit_xml(results: list[ScenarioResult], report_path: str, words: Wording = RUN) -> str:
    suite = ET.Element("testsuite", name="kartci", tests=str(len(results)))
    failures = errors = 0
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="kartci.scenarios", name=r.name,
                             time=str(r.run.get("wall_s", 0)))
        if r.error:
            errors += 1
            ET.SubElement(case, "error", message=r.error).text = r.error
        else:
            problems = [f"criterion {c.name} {c.bound}: got {num(c.value)}"
                        for c in r.criteria if not c.ok]
            problems += [f"{v.name} {v.status.value}: {num(v.value, v.unit)} vs {words.base} "
                         f"{num(v.baseline, v.unit)}" for v in r.verdicts if v.status.bad]
            if problems:
                failures += 1
                ET.SubElement(case, "failure", message=problems[0]).text = "\n".join(problems)
        ET.SubElement(case, "system-out").text = f"report: {report_path}"
    suite.set("failures", str(failures))
    suite.set("errors", str(errors))
    return ET.tostring(suite, encoding="unicode", xml_declaration=True) + "\n"
