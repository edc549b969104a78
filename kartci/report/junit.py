"""JUnit XML: a test case per scenario, a failure element per regressed or failed metric (the
`failures` count is of failed scenarios), the report path in system-out."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from kartci.report.tables import RUN, Wording, num
from kartci.verdict.result import ScenarioResult


def xml_text(text: str) -> str:
    """Text XML 1.0 can hold: user text (an error message) may carry control characters, which
    ElementTree would write as they are, giving a file no CI can parse."""
    return "".join(c if c in "\t\n\r" or (c >= " " and c not in "\ufffe\uffff")
                   else "\ufffd" for c in text)


def junit_xml(results: list[ScenarioResult], report_path: str, words: Wording = RUN) -> str:
    """junit.xml: a test case per scenario with a failure per failing metric, failed criterion or
    gate problem, or an error when it did not run."""
    suite = ET.Element("testsuite", name="kartci", tests=str(len(results)))
    failures = errors = 0
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="kartci.scenarios", name=r.name,
                             time=str(r.run.get("wall_s", 0)))
        if r.error:
            errors += 1
            text = xml_text(r.error)
            ET.SubElement(case, "error", message=text).text = text
        else:
            problems = [xml_text(p) for p in r.problems]
            problems += [f"criterion {c.name} {c.bound}: got {num(c.value)}"
                         for c in r.criteria if not c.ok]
            problems += [f"{v.name} {v.status.value}: {num(v.value, v.unit)} vs {words.base} "
                         f"{num(v.baseline, v.unit)}" for v in r.verdicts if v.status.bad]
            failures += bool(problems)
            for problem in problems:  # one failure element per regressed or failed metric
                ET.SubElement(case, "failure", message=problem, type="kartci").text = problem
        ET.SubElement(case, "system-out").text = xml_text("\n".join(
            [f"report: {report_path}", *(f"warning: {w}" for w in r.warnings)]))
    suite.set("failures", str(failures))
    suite.set("errors", str(errors))
    return ET.tostring(suite, encoding="unicode", xml_declaration=True) + "\n"
