"""Entry point of the ch. 4 learners: PIIRL sensitivity recovery and its active-learning loop."""

from pliant.hookspecs import hookimpl

_MODULE = "pliant_piirl.learner"


@hookimpl
def pliant_register(registrar):
    registrar.add("learner", "piirl", f"{_MODULE}:PiirlLearner",
                  description="object sensitivities from demonstrations by PIIRL (thesis 4.3.3, eq. 4.1)")
    registrar.add("learner", "active-piirl", f"{_MODULE}:ActivePiirlLearner",
                  description="Alg. 2-3 choose demonstrations, a simulated expert shows them, PIIRL learns (ch. 4)")
