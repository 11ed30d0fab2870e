import { describe, expect, it } from 'vitest';
import { tokenizeLine } from './wrl-language';

const styles = (line: string) => tokenizeLine(line).map(([t, s]) => `${t}:${s}`);

describe('wrl tokenizer', () => {
  it('highlights statements, constructors, numbers and comments', () => {
    expect(styles("MOVEP POSE(250, 100, 20, 30), L   ' elbow left")).toEqual([
      'MOVEP:keyword',
      'POSE:variableName.standard',
      '(:paren',
      '250:number',
      ',:separator',
      '100:number',
      ',:separator',
      '20:number',
      ',:separator',
      '30:number',
      '):paren',
      ',:separator',
      'L:atom',
      "' elbow left:lineComment",
    ]);
  });

  it('is case-insensitive and tells control keywords, operators and booleans', () => {
    expect(styles('if n <= 3 and not In(4) then')).toEqual([
      'if:controlKeyword',
      'n:variableName',
      '<=:compareOperator',
      '3:number',
      'and:logicOperator',
      'not:logicOperator',
      'In:variableName.standard',
      '(:paren',
      '4:number',
      '):paren',
      'then:controlKeyword',
    ]);
    expect(styles('X = TRUE')).toEqual(['X:variableName', '=:compareOperator', 'TRUE:bool']);
  });

  it('reads strings with doubled quotes and unclosed strings', () => {
    expect(styles('PRINT "say ""hi""", 1')).toEqual(['PRINT:keyword', '"say ""hi""":string', ',:separator', '1:number']);
    expect(styles('PRINT "open')).toEqual(['PRINT:keyword', '"open:string']);
  });

  it('reads numbers with fractions and exponents', () => {
    expect(styles('A = .5 + 1e3 - 2.5E-3')).toEqual([
      'A:variableName',
      '=:compareOperator',
      '.5:number',
      '+:arithmeticOperator',
      '1e3:number',
      '-:arithmeticOperator',
      '2.5E-3:number',
    ]);
  });

  it('marks fields, SUB definitions, CALLs and bad characters', () => {
    expect(styles('PRINT P.X, HERE().YAW')).toEqual([
      'PRINT:keyword',
      'P:variableName',
      '.:punctuation',
      'X:propertyName',
      ',:separator',
      'HERE:variableName.standard',
      '(:paren',
      '):paren',
      '.:punctuation',
      'YAW:propertyName',
    ]);
    expect(styles('SUB grip')).toEqual(['SUB:controlKeyword', 'grip:variableName.definition']);
    expect(styles('CALL grip')).toEqual(['CALL:controlKeyword', 'grip:variableName.function']);
    expect(styles('X = 1 ; Y')).toContain(';:invalid');
  });

  it('does not take L as a posture outside MOVEP', () => {
    expect(styles('L = 3')).toEqual(['L:variableName', '=:compareOperator', '3:number']);
  });
});
